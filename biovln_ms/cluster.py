"""Ray, the way this package's work leaves one machine: the address rule and starting or joining a cluster;
and how a process with workers of its own (a process pool, a vector env's processes or Ray actors) ends
them on SIGTERM, ^C or an error, without waiting for work in flight.

Evaluation actors, training env actors and training-split builds all start Ray here, so an address is
checked, a silent head node refused and Ray's own errors turned into one line in one place. Ray is an
optional dependency (``pip install 'biovln-ms[cluster]'``) and is imported only when used.
"""

from __future__ import annotations

import contextlib
import re
import signal
import socket
import sys
import threading
import time
from types import ModuleType

from biovln_ms.errors import BioVLNError

#: a Ray address: a local instance, the running cluster, or a head node
RAY_ADDRESS = re.compile(r"local|auto|(ray://)?[A-Za-z0-9][A-Za-z0-9.\-]*:[0-9]{1,5}")
RAY_ADDRESS_RULE = "'local' (a local instance), 'auto' (the running cluster) or 'ray://HOST:PORT'"
RAY_CONNECT_TIMEOUT_S = 10  # a head node that does not accept a connection in this time is refused


class ClusterError(BioVLNError):
    """Ray is missing, the address is malformed, or the cluster cannot be started or joined."""


def check_address(address: object) -> None:
    """Refuse anything but a Ray address (``RAY_ADDRESS_RULE``), before any work starts."""
    if not isinstance(address, str) or not RAY_ADDRESS.fullmatch(address):
        raise ClusterError(
            f"{str(address)[:60]!r} is not a Ray address", field="ray_address", fix=f"use {RAY_ADDRESS_RULE}"
        )


def _reachable(address: str, timeout_s: float) -> None:
    """Refuse a head node that does not answer (Ray itself would wait minutes for it)."""
    if address in ("local", "auto"):
        return
    host, _, port = address.removeprefix("ray://").rpartition(":")
    try:
        socket.create_connection((host, int(port)), timeout=timeout_s).close()
    except OSError as e:
        raise ClusterError(
            f"no Ray head node answers at '{address}' ({e.strerror or e})",
            field="ray_address",
            fix="start the cluster first (ray start --head), check the host and port, or use 'local'",
        ) from None


def start_ray(
    address: str, num_cpus: int, timeout_s: float = RAY_CONNECT_TIMEOUT_S
) -> tuple[ModuleType, bool]:
    """Ray, started (``'local'``, with ``num_cpus``) or joined, and whether this call started it.

    A caller that started Ray shuts it down when done; one that found it running leaves it.
    """
    check_address(address)
    try:
        import ray
    except ImportError:
        raise ClusterError(
            "--ray-address needs Ray", field="ray_address", fix="pip install 'biovln-ms[cluster]'"
        ) from None
    if ray.is_initialized():
        return ray, False
    _reachable(address, timeout_s)
    try:
        if address == "local":
            ray.init(num_cpus=max(1, int(num_cpus)), include_dashboard=False, log_to_driver=False)
        else:
            ray.init(address=address, log_to_driver=False)
    except Exception as e:  # ConnectionError, RuntimeError, ValueError: Ray's words, on one line
        raise ClusterError(
            f"cannot start or join Ray at '{address}': {type(e).__name__}: {' '.join(str(e).split())[:300]}",
            field="ray_address",
            fix=f"start the cluster first (ray start --head) or use {RAY_ADDRESS_RULE}",
        ) from None
    return ray, True


def exit_on_sigterm():
    """While worker processes run (an evaluation's pool, a training's envs), a SIGTERM (``kill``'s default)
    ends this process as ^C does, so that its cleanup stops them rather than leaving them running on their
    own; returns what puts the previous handler back."""
    if threading.current_thread() is not threading.main_thread():  # only the main thread may set one
        return lambda: None
    previous = signal.getsignal(signal.SIGTERM)  # None: set outside Python, restored as the default
    signal.signal(signal.SIGTERM, lambda signum, frame: sys.exit(128 + signum))
    return lambda: signal.signal(signal.SIGTERM, signal.SIG_DFL if previous is None else previous)


def stop_process_pool(pool) -> None:
    """Shut a ``ProcessPoolExecutor`` down without waiting for the work still running (after an error, ^C
    or SIGTERM): its workers are ended, and gone when this returns."""
    workers = list((getattr(pool, "_processes", None) or {}).values())  # shutdown() forgets them
    pool.shutdown(wait=False, cancel_futures=True)
    _end(workers)


def end_env_processes(venv) -> None:
    """End a vector env's worker processes without the close handshake, after a SIGTERM, ^C or error.

    Interrupted inside ``step_wait``, Stable-Baselines3's ``SubprocVecEnv`` may already have read one
    worker's reply while ``waiting`` is still set, so its ``close`` would wait for that reply again, for ever.
    A vector env with a ``terminate()`` of its own (``RayVecEnv``: its actors) is ended by it; in-process
    vector envs have no workers (``close`` ends those)."""
    base = venv.unwrapped
    terminate = getattr(base, "terminate", None)
    if callable(terminate):
        terminate()
        return
    processes = getattr(base, "processes", None)
    if processes is None or getattr(base, "closed", False):
        return
    _end(processes)
    for remote in getattr(base, "remotes", ()):
        remote.close()
    base.closed = True


@contextlib.contextmanager
def closing_vec_env(venv):
    """Yield ``venv`` and close it when the block ends; if the block raised (a kill, ^C or an error), end
    its worker processes first (:func:`end_env_processes`), as a close handshake may wait for ever."""
    try:
        yield venv
    except BaseException:
        end_env_processes(venv)
        raise
    finally:
        venv.close()


def stop_ray_work(ray: ModuleType, actors=(), tasks=()) -> None:
    """Kill Ray ``actors`` and cancel ``tasks`` (object refs) without waiting for them; one already gone, or
    a failing Ray, is passed over, so that the error in flight stays the one the user sees."""
    for actor in actors:
        try:
            ray.kill(actor)
        except Exception:
            pass
    for ref in tasks:
        try:
            ray.cancel(ref, force=True)
        except Exception:
            pass


def _end(processes) -> None:
    """Terminate ``processes``, then kill any still alive 10 s later; all are gone when this returns."""
    for proc in processes:
        if proc.is_alive():
            proc.terminate()
    deadline = time.monotonic() + 10
    for proc in processes:
        proc.join(timeout=max(0.0, deadline - time.monotonic()))
    for proc in processes:
        if proc.is_alive():
            proc.kill()
            proc.join()
