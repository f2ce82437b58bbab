"""Several envs per worker process, for Stable-Baselines3 on the CPU.

SB3's ``SubprocVecEnv`` runs one env per process, so every env step costs an inter-process round trip;
ManiSkill's CPU backend holds one env per ``gym.make`` (``num_envs > 1`` needs the GPU), so batching in
one env is not open there. :class:`GroupedSubprocVecEnv` runs ``n`` envs in ``processes`` workers, each
stepping its group in turn through SB3's own ``DummyVecEnv`` (its auto-reset, ``terminal_observation``
and ``TimeLimit.truncated``), so a round trip carries ``n / processes`` env steps. Env ``i`` is built
by ``env_fns[i]`` and seeded ``seed + i`` as in ``SubprocVecEnv``: the same envs give the same
transitions, only the time differs (rewards come as ``DummyVecEnv``'s float32).
"""

from __future__ import annotations

import multiprocessing as mp
import traceback
from typing import Any, Callable, Sequence

import gymnasium as gym
import numpy as np
from stable_baselines3.common.vec_env import DummyVecEnv, VecEnv
from stable_baselines3.common.vec_env.base_vec_env import CloudpickleWrapper, VecEnvIndices

from biovln_ms.errors import BioVLNError


class _Failed(str):
    """A worker's last answer when a step or reset raised: the exception's last line (the traceback went to
    stderr); the worker has ended."""


class _Raised:
    """A worker's answer when an attribute or method call raised: the exception, raised again here."""

    def __init__(self, error: BaseException) -> None:
        self.error = error


def _worker(remote, parent_remote, fns: CloudpickleWrapper) -> None:
    """One process: a ``DummyVecEnv`` of its group, answering the parent's commands (indices local)."""
    parent_remote.close()
    venv = None
    try:
        venv = DummyVecEnv(fns.var)
        while True:
            try:
                cmd, data = remote.recv()
            except EOFError:
                break
            if cmd == "step":
                obs, rewards, dones, infos = venv.step(data)
                remote.send((obs, rewards, dones, infos, venv.reset_infos))
            elif cmd == "reset":
                venv._seeds, venv._options = data
                remote.send((venv.reset(), venv.reset_infos))
            elif cmd == "spaces":
                remote.send((venv.observation_space, venv.action_space))
            elif cmd == "close":
                break
            else:  # attribute and method calls: an error is the caller's, and the worker lives on
                try:
                    remote.send(_call(venv, cmd, data))
                except Exception as e:
                    remote.send(_Raised(e))
    except KeyboardInterrupt:
        pass
    except Exception as e:  # the parent raises it as a one-line error; the traceback goes to stderr
        traceback.print_exc()
        remote.send(_Failed(traceback.format_exception_only(e)[-1].strip()))
    finally:
        if venv is not None:
            venv.close()
        remote.close()


def _call(venv: DummyVecEnv, cmd: str, data: Any) -> Any:
    if cmd == "get_attr":
        return venv.get_attr(*data)
    if cmd == "has_attr":
        return venv.has_attr(data)
    if cmd == "set_attr":
        venv.set_attr(*data)
        return []
    if cmd == "env_method":
        name, args, kwargs, indices = data
        return venv.env_method(name, *args, indices=indices, **kwargs)
    if cmd == "is_wrapped":
        return venv.env_is_wrapped(*data)
    raise ValueError(f"unknown command {cmd!r}")


def _concat(parts: list) -> Any:
    """Observations of the groups, in env order (arrays, or dicts of arrays)."""
    if isinstance(parts[0], dict):
        return {k: np.concatenate([p[k] for p in parts]) for k in parts[0]}
    return np.concatenate(parts)


class GroupedSubprocVecEnv(VecEnv):
    """``len(env_fns)`` envs in ``processes`` worker processes (contiguous groups, as even as possible);
    ``start_method`` as ``SubprocVecEnv``'s (spawn: no inherited simulator state)."""

    def __init__(
        self,
        env_fns: Sequence[Callable[[], gym.Env]],
        processes: int,
        start_method: str = "spawn",
    ) -> None:
        n = len(env_fns)
        if not 1 <= processes <= n:
            raise ValueError(f"processes must be in 1..{n} (the number of envs), got {processes}")
        bounds = np.cumsum([0] + [len(g) for g in np.array_split(np.arange(n), processes)])
        self.groups = [(int(a), int(b)) for a, b in zip(bounds[:-1], bounds[1:])]
        ctx = mp.get_context(start_method)
        self.remotes, self.processes = [], []
        for a, b in self.groups:
            remote, work_remote = ctx.Pipe()
            args = (work_remote, remote, CloudpickleWrapper(list(env_fns[a:b])))
            proc = ctx.Process(target=_worker, args=args, daemon=True)
            proc.start()
            work_remote.close()
            self.remotes.append(remote)
            self.processes.append(proc)
        self.pending: set[int] = set()  # workers whose answer is still to be read
        self.closed = False
        self._send(0, "spaces", None)
        observation_space, action_space = self._recv(0)
        super().__init__(n, observation_space, action_space)

    def _send(self, g: int, cmd: str, data: Any) -> None:
        self.remotes[g].send((cmd, data))
        self.pending.add(g)

    def _recv(self, g: int) -> Any:
        """Worker ``g``'s answer; its failure, or its end, as a one-line error."""
        a, b = self.groups[g]
        self.pending.discard(g)
        try:
            answer = self.remotes[g].recv()
        except (EOFError, OSError):  # OSError: a message cut off, the pipe reset
            answer = _Failed("the process ended")
        if isinstance(answer, _Raised):
            raise answer.error
        if isinstance(answer, _Failed):
            raise BioVLNError(
                f"env process {g} (envs {a}..{b - 1}) failed: {answer}",
                field="env",
                fix="the worker's traceback is printed above",
            )
        return answer

    def _rows(self, indices: VecEnvIndices) -> list[tuple[int, list[int]]]:
        """(group, its local indices) of global ``indices``, in the order given."""
        out: list[tuple[int, list[int]]] = []
        for i in self._get_indices(indices):
            if not -self.num_envs <= i < self.num_envs:
                raise IndexError(f"env index {i} out of range for {self.num_envs} envs")
            i %= self.num_envs  # a negative index counts from the end, as in a list
            g = next(k for k, (a, b) in enumerate(self.groups) if a <= i < b)
            if out and out[-1][0] == g:
                out[-1][1].append(i - self.groups[g][0])
            else:
                out.append((g, [i - self.groups[g][0]]))
        return out

    def _ask(self, cmd: str, indices: VecEnvIndices, make: Callable[[list[int]], Any]) -> list:
        """``cmd`` to the workers holding ``indices``; their answers (lists), in the order of ``indices``."""
        rows = self._rows(indices)
        for g, local in rows:
            self._send(g, cmd, make(local))
        return [x for g, _ in rows for x in self._recv(g)]

    def _all(self, cmd: str, data: Callable[[int, int], Any]) -> list:
        """``cmd`` to every worker (``data(a, b)`` for its envs a..b-1); their answers in order."""
        for g, (a, b) in enumerate(self.groups):
            self._send(g, cmd, data(a, b))
        return [self._recv(g) for g in range(len(self.groups))]

    def step_async(self, actions: np.ndarray) -> None:
        for g, (a, b) in enumerate(self.groups):
            self._send(g, "step", actions[a:b])

    def step_wait(self):
        obs, rewards, dones, infos, reset_infos = zip(*[self._recv(g) for g in range(len(self.groups))])
        self.reset_infos = [x for part in reset_infos for x in part]
        infos = [x for part in infos for x in part]
        return _concat(list(obs)), np.concatenate(rewards), np.concatenate(dones), infos

    def reset(self):
        obs, reset_infos = zip(*self._all("reset", lambda a, b: (self._seeds[a:b], self._options[a:b])))
        self.reset_infos = [x for part in reset_infos for x in part]
        self._reset_seeds()
        self._reset_options()
        return _concat(list(obs))

    def close(self) -> None:
        if not self.closed:
            for g, remote in enumerate(self.remotes):
                try:
                    if g in self.pending:  # an answer left unread (another worker failed first)
                        remote.recv()
                    remote.send(("close", None))
                except (EOFError, OSError):
                    pass  # that worker has already ended
        for proc in self.processes:
            proc.join(timeout=30)
            if proc.is_alive():
                proc.terminate()
        for remote in self.remotes:
            remote.close()
        self.closed = True

    def get_attr(self, attr_name: str, indices: VecEnvIndices = None) -> list[Any]:
        return self._ask("get_attr", indices, lambda rows: (attr_name, rows))

    def has_attr(self, attr_name: str) -> bool:
        return all(self._all("has_attr", lambda a, b: attr_name))

    def set_attr(self, attr_name: str, value: Any, indices: VecEnvIndices = None) -> None:
        self._ask("set_attr", indices, lambda rows: (attr_name, value, rows))

    def env_method(self, method_name: str, *method_args, indices: VecEnvIndices = None, **method_kwargs):
        return self._ask("env_method", indices, lambda rows: (method_name, method_args, method_kwargs, rows))

    def env_is_wrapped(self, wrapper_class: type[gym.Wrapper], indices: VecEnvIndices = None) -> list[bool]:
        return self._ask("is_wrapped", indices, lambda rows: (wrapper_class, rows))
