"""The task's own state in ``get_state_dict()["task"]`` and its checks: what a replay needs beyond the
simulation's (each sub-env's episode, start pose, elapsed steps, episode seed, actuation error, every
measure's state and the people's), so ``set_state_dict`` gives back the same rewards and infos.

The task's integers go out as float64, exact below 2**53: a recorded step's one-number integer is a NumPy
integer scalar, which ManiSkill's trajectory tools cannot batch (``replay_trajectory --use-env-states
--save-traj``), while floats and flags they can. Loading takes either.
"""

from __future__ import annotations

from collections.abc import Mapping
import numpy as np
import torch
from mani_skill.envs.sapien_env import BaseEnv

from biovln_ms.tasks.config_checks import EnvConfigError, _show


def task_state(env: BaseEnv) -> dict:
    """The task's part of ``env.get_state_dict()`` (``env``: a ``BioVLNNavEnv``)."""
    task = dict(
        episode=env._episode_indices(),
        start=torch.tensor(env._start, device=env.device),
        elapsed_steps=torch.as_tensor(env._elapsed_steps).clone(),
        done=torch.tensor(env._done, device=env.device),
        episode_seed=torch.tensor(env._episode_seed, device=env.device),  # seeds the actuation noise
        actuation_error=torch.tensor(env.agent.controller.actuation_error, device=env.device),
        measures=env._measures.state_dict(),
    )
    if env._people:  # the crowds' (their figures' poses are ManiSkill's actor state)
        task["people"] = env._people.state_dict()
    return _integers_as_float(task)


def load_task_state(env: BaseEnv, given: dict, reference: dict, env_idx: torch.Tensor | None) -> None:
    """Put a checked (:func:`check_state`) task state into sub-envs ``env_idx`` (all when None), which must
    be at the state's episodes."""
    task = state_rows(given, reference, env.num_envs)
    idx = torch.arange(env.num_envs, device=env.device) if env_idx is None else env_idx.to(env.device)
    saved = task["episode"].to(env.device, torch.int64)
    if not torch.equal(saved[idx], env._episode_indices()[idx]):
        raise EnvConfigError(
            "the state belongs to another episode",
            field="state['task']['episode']",
            fix="reset to that episode first: env.reset(options={'episode_index': k})",
        )
    rows = idx.cpu().numpy()
    env._start[rows] = torch.as_tensor(task["start"]).cpu().numpy()[rows]
    steps = torch.as_tensor(task["elapsed_steps"], device=env.device)[idx]
    env._elapsed_steps[idx] = steps.to(env._elapsed_steps.dtype)
    env._done[rows] = torch.as_tensor(task["done"]).cpu().numpy()[rows]
    env._episode_seed[rows] = torch.as_tensor(task["episode_seed"]).cpu().numpy()[rows]
    env.agent.controller.actuation_error[rows] = torch.as_tensor(task["actuation_error"]).cpu().numpy()[rows]
    env._measures.load_state_dict(task["measures"], idx)
    if env._people:
        env._people.load_state_dict(task["people"], rows)


def _integers_as_float(tree):
    """``tree`` with its integer tensors as float64 (see the module's docstring)."""
    if isinstance(tree, dict):
        return {k: _integers_as_float(v) for k, v in tree.items()}
    floating = tree.is_floating_point() or tree.dtype == torch.bool
    return tree if floating else tree.to(torch.float64)


def check_state(state, reference: dict, num_envs: int) -> None:
    """A state for ``set_state_dict``: keys of ``reference`` (the env's own ``get_state_dict()``; the
    simulation's may be left out, the task's come whole), arrays of its shapes (unbatched, or a row per
    sub-env) and finite numbers; the measures' states may hold NaN and infinities (a measure's "none" or
    "unreachable", as Fetch's reach configuration out of reach or a geodesic distance off the navmesh)."""
    _check_tree(state, reference, "state", num_envs, whole=False, any_float=False)


def state_rows(state, reference, num_envs: int):
    """A checked (:func:`check_state`) state subtree with every array as one row per sub-env: an unbatched
    array, one step of a recording as ManiSkill's trajectory tools hand it back, goes to every row, as
    ManiSkill's ``set_state_dict`` does with an unbatched simulation state."""
    if isinstance(reference, dict):
        return {k: state_rows(v, reference[k], num_envs) for k, v in state.items()}
    a = torch.as_tensor(state.cpu() if isinstance(state, torch.Tensor) else np.asarray(state))
    shape = tuple(reference.shape[1:])
    return a.expand(num_envs, *shape) if a.shape == shape else a


def _check_tree(given, ref, path: str, n: int, whole: bool, any_float: bool) -> None:
    if isinstance(ref, dict):
        if not isinstance(given, Mapping):
            raise EnvConfigError(
                f"{path} must be a dict, got {type(given).__name__}", field=path, fix=_STATE_FIX
            )
        unknown = [k for k in given if k not in ref]
        missing = [k for k in ref if k not in given] if whole else []
        if unknown or missing:
            what = f"unknown key {_show(unknown[0])}" if unknown else f"no key {_show(missing[0])}"
            raise EnvConfigError(f"{path} has {what}", field=path, fix=_STATE_FIX)
        for k, v in given.items():
            measures = whole and k == "measures"
            _check_tree(v, ref[k], f"{path}[{_show(k)}]", n, whole or k == "task", any_float or measures)
        return
    try:
        a = np.asarray(given.cpu() if isinstance(given, torch.Tensor) else given)
    except (TypeError, ValueError, RuntimeError):
        a = np.asarray(None)
    shape = tuple(ref.shape[1:])
    ok = a.dtype.kind in "biuf" and a.shape in ((n, *shape), shape)
    if ok and a.dtype.kind == "f" and not any_float:
        ok = bool(np.isfinite(a).all())
    if not ok:
        numbers = "numbers" if any_float else "finite numbers"
        raise EnvConfigError(
            f"{path} must be {numbers} of shape {(n, *shape)} or {shape}, got {getattr(a, 'shape', None)}",
            field=path,
            fix=_STATE_FIX,
        )


_STATE_FIX = "pass a state from env.get_state_dict() of this env"
