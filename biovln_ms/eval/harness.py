"""The evaluation harness: run a method on a split, one JSON line per finished episode.

``out/<run>/<split>/episodes.jsonl`` is append-only: each finished episode is written as one line and
flushed to disk, so a killed run resumes (``evaluate`` again) without losing or repeating an episode;
a half-written last line from a kill is repaired. Episodes run in worker processes (``workers``,
default one per core, started with ``spawn``); they return records, and the driver alone writes.
``summary.json`` holds the aggregates.

One writer per run folder: ``evaluate`` holds an exclusive ``flock`` on ``<run folder>/eval.lock`` for
the whole run; a second one fails at once naming the first (pid, start, command). The kernel frees the
lock when its process dies, so a killed run's folder is taken over by the next ``evaluate``.

An episode that raises, or whose record has a missing or non-finite metric, is recorded with an
``error`` and counts as a failure (``metrics.record_error``); a resume runs it again, replacing that
record. A file with more than one finished record of an episode (two writers without the lock) is
repaired on resume: the first record of each episode is kept, and the repaired keys are named.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import re
import time
from dataclasses import asdict, dataclass, field
from importlib import metadata
from pathlib import Path

import numpy as np

from biovln_ms.variants import BENCHMARK_ENV
from biovln_ms.cluster import check_address, exit_on_sigterm, start_ray, stop_process_pool, stop_ray_work
from biovln_ms.errors import BioVLNError
from biovln_ms.eval.methods import method_spec
from biovln_ms.eval.aggregate import aggregate_all, record_error
from biovln_ms.eval.handoff import handoff_payload, write_handoff
from biovln_ms.eval.rollout import rollout
from biovln_ms.io_utils import atomic_write_text, exclusive_lock, inside
from biovln_ms.measured import source_commit
from biovln_ms.limits import ID_CHARS, ID_RULE, MAX_ID_LENGTH, MAX_WORKERS, RUN_NAME_CHARS, RUN_NAME_RULE
from biovln_ms.metrics.measures import OUTCOME, DistanceToGoal, Metric, measure_type
from biovln_ms.metrics.reach_measures import REACH_MEASURES
from biovln_ms.noise import resolve_noise
from biovln_ms.plugins import load_plugins, loaded_plugins
from biovln_ms.robot_specs import DEFAULT_ROBOT, robot_spec
from biovln_ms.variants import VARIANTS

DEFAULT_ENV = BENCHMARK_ENV  # the env of a method that names none
LOCK_FILE = "eval.lock"  # in the run folder, held by the one process writing there


class ResultsError(BioVLNError):
    """A corrupt or mismatching results file."""


@dataclass
class EvalConfig:
    method: str
    split: str
    out: str
    dataset: str | None = None
    env_id: str | None = (
        None  # None: the method's env (the RL variant for ppo/a2c/sac), else BioVLN-OpFace-v0
    )
    workers: int | None = None
    camera: tuple[int, int] = (640, 480)
    max_episodes: int | None = None
    method_kwargs: dict = field(default_factory=dict)
    ray_address: str | None = (
        None  # "local" starts a local Ray instance; "auto" or "ray://host:port" joins one
    )
    record_dir: str | None = None  # TrajectoryRecorder output (learning from the runs)
    record_mode: str = "full"  # "full" (PNG frames + depth) or "trace" (positions, actions, goals only)
    name: str | None = None  # results folder name (default: the method, plus the variant when not OpFace)
    noise: str = "ideal"  # a noise preset (biovln_ms.noise.PRESETS)
    robot: str = (
        DEFAULT_ROBOT  # a biovln_ms.robot_specs.ROBOTS id; its own dataset unless ``dataset`` is given
    )
    handoff_dir: str | None = None  # write each successful episode's hand-off here (biovln_ms.eval.handoff)
    fresh_scene: bool = False  # rebuild the scene at every reset: outcomes independent of a worker's history
    plugins: list[str] = field(
        default_factory=loaded_plugins
    )  # imported by each worker first (biovln_ms.plugins)

    def __post_init__(self) -> None:
        robot_spec(self.robot, "robot")
        if self.env_id is None:
            self.env_id = method_spec(self.method).env_id or DEFAULT_ENV
        resolve_noise(self.noise)  # a one-line error before any worker starts: an unknown preset
        check_options(self)

    @property
    def run_name(self) -> str:
        return self.name or run_name(self.method, self.env_id, self.robot, self.noise)

    @property
    def run_dir(self) -> Path:
        """``out/<run>/<split>``: ``out`` a folder, the split one name, the whole inside ``out``."""
        if not str(self.out).strip():
            raise BioVLNError(
                "--out is empty (it would write into the current folder)", field="--out", fix="name a folder"
            )
        if len(self.split) > MAX_ID_LENGTH or not re.fullmatch(ID_CHARS, self.split):
            raise BioVLNError(
                f"split {self.split[:60]!r} is not a split name", field="--split", fix=f"use {ID_RULE}"
            )
        return inside(self.out, self.run_name, self.split, what="run folder", field="name")


def run_name(method: str, env_id: str | None = None, robot: str = DEFAULT_ROBOT, noise: str = "ideal") -> str:
    """The results folder ``biovln-ms eval`` names a run of ``method`` on ``env_id`` (None: the method's
    env) with ``robot`` under noise ``noise`` when no ``--name`` is given:
    ``METHOD[@variant][-robot][+preset]`` (``frontier@centroid-fetch+realistic``). A name only: nothing is
    checked and no run is configured."""
    if env_id is None:
        env_id = method_spec(method).env_id or DEFAULT_ENV
    suffix = "" if env_id == DEFAULT_ENV else "@" + env_id.removeprefix("BioVLN-").removesuffix("-v0").lower()
    return (
        method
        + suffix
        + ("" if robot == DEFAULT_ROBOT else f"-{robot}")
        + ("" if noise == "ideal" else f"+{noise}")
    )


def check_options(cfg: EvalConfig) -> None:
    """One-line errors for options no run can use, before anything is written: a run name that is not one
    plain name (it would leave ``out``), a count below one (``max_episodes`` 0 would mean all and -3 all
    but three) and an empty folder (it would mean the current one). ``run_dir`` checks ``out`` and the
    split, which some callers leave empty to get the run name alone."""

    def refuse(field: str, message: str, fix: str) -> BioVLNError:
        return BioVLNError(message, field=field, fix=fix)

    name = cfg.run_name
    if len(name) > MAX_ID_LENGTH or not re.fullmatch(RUN_NAME_CHARS, name):
        raise refuse(
            "--name",
            f"run name {name[:60]!r} is not a plain folder name",
            f"use {RUN_NAME_RULE}",
        )
    for key, flag, top in (("max_episodes", "--max-episodes", None), ("workers", "--workers", MAX_WORKERS)):
        value = getattr(cfg, key)
        if value is None:
            continue
        if type(value) is not int or value < 1 or (top is not None and value > top):
            bound = f"1 to {top:,}" if top else "1 or more; leave it out to run all"
            raise refuse(flag, f"{flag} {value!r} is out of range", f"use {bound}")
    if cfg.ray_address is not None:
        check_address(cfg.ray_address)
    for key, flag in (("record_dir", "--record"), ("handoff_dir", "--export-handoff")):
        value = getattr(cfg, key)
        if value is not None and not str(value).strip():
            raise refuse(flag, f"{flag} is empty (it would write into the current folder)", "name a folder")


def _protocol_env(env_id: str) -> bool:
    """Whether ``env_id`` runs protocol (multi-goal) episodes."""
    return env_id in VARIANTS and VARIANTS[env_id].protocol


def episode_key(ep: dict) -> str:
    return f"{ep['scene_id']}/{ep['episode_id']}"


def load_records(path: Path, repair: bool = True) -> list[dict]:
    """Records of a JSONL file; a truncated last line (a killed run) is cut off when ``repair``."""
    if not path.exists():
        return []
    data = path.read_bytes()
    lines = data.split(b"\n")
    out, good_end = [], 0
    for i, line in enumerate(lines):
        if not line.strip():
            good_end += len(line) + 1
            continue
        try:
            out.append(json.loads(line))
            good_end += len(line) + 1
        except json.JSONDecodeError:
            if i == len(lines) - 1 or all(not x.strip() for x in lines[i + 1 :]):
                if repair:
                    with open(path, "r+b") as f:
                        f.truncate(min(good_end, len(data)))
                break
            raise ResultsError(
                f"line {i + 1} is not valid JSON",
                source=str(path),
                fix="delete that line (the episode will be run again) or the file",
            ) from None
    return out


def unique_records(records: list[dict]) -> tuple[list[dict], list[str]]:
    """One record per episode, in file order: its first finished record, else (only errors) its last
    errored one. Also the keys that had more than one finished record (duplicates)."""
    chosen: dict[str, dict] = {}
    finished: dict[str, int] = {}
    for r in records:
        key = episode_key(r)
        if record_error(r) is None:
            finished[key] = finished.get(key, 0) + 1
            if finished[key] == 1:
                chosen[key] = r
        elif key not in finished:
            chosen.pop(key, None)  # re-inserted last: a retried episode's record is where it was written
            chosen[key] = r
    return list(chosen.values()), [k for k, c in finished.items() if c > 1]


def _name_keys(keys: list[str], limit: int = 5) -> str:
    more = f" and {len(keys) - limit} more" if len(keys) > limit else ""
    return ", ".join(keys[:limit]) + more


# --- workers -------------------------------------------------------------------------------------
_W: dict = {}


def _init_worker(cfg: dict) -> None:
    import gymnasium as gym
    import torch

    import biovln_ms  # noqa: F401

    load_plugins(cfg.get("plugins", ()))

    torch.set_num_threads(1)
    spec = method_spec(cfg["method"])
    policy = spec.factory(**cfg["method_kwargs"])  # first: a bad checkpoint fails before an env is built
    w, h = cfg["camera"]
    recorder = None
    obs_mode = cfg["obs_mode"]
    if cfg.get("record_dir"):
        from biovln_ms.learning.recorder import TrajectoryRecorder

        recorder = TrajectoryRecorder(cfg["record_dir"], cfg.get("record_mode", "full"))
        if recorder.needs_images and obs_mode in ("none", "depth"):  # demonstrations keep RGB-D
            obs_mode = "rgbd"
    env = gym.make(
        cfg["env_id"],
        split=cfg["split"],
        dataset=cfg["dataset"],
        obs_mode=obs_mode,
        camera_width=w,
        camera_height=h,
        sim_backend="physx_cpu",
        render_backend="cpu",
        noise=cfg.get("noise", "ideal"),
        robot_uids=cfg.get("robot", DEFAULT_ROBOT),
        **spec.env_kwargs,
    )
    _W.update(
        env=env,
        policy=policy,
        cfg=cfg,
        recorder=recorder,
        privileged=spec.privileged,
    )


def _r4(v) -> float:
    return round(float(v), 4)


def _recorded(u, info: dict) -> list[tuple[str, Metric, type]]:
    """(info key, metric, measure) of what an episode's record holds: the variant's measures with a metric
    (its success measure's value is ``info``'s outcome), then those only some robots report."""
    names = dict.fromkeys(u.cfg.measures + REACH_MEASURES)
    out = []
    for name in names:
        cls = measure_type(name)
        if name in info and cls.metric is not None:
            out.append((OUTCOME if cls.metric.key == OUTCOME else name, cls.metric, cls))
    return out


def _first(v) -> np.ndarray:
    """Sub-env 0's value of an ``info`` entry (a tensor or array with a leading ``num_envs`` dimension)."""
    v = np.asarray(v.cpu() if hasattr(v, "cpu") else v)
    return v[0] if v.ndim else v


def _value(v, dtype):
    """One recorded value of a measure, as JSON: bool, int or float by the measure's type."""
    kind = np.dtype(dtype).kind
    return bool(v) if kind == "b" else int(v) if kind in "iu" else float(v)


def _run(index: int) -> dict:
    env, policy, cfg, recorder = _W["env"], _W["policy"], _W["cfg"], _W.get("recorder")
    u = env.unwrapped
    t0 = time.perf_counter()
    ep = None
    try:
        actions, poses = [], []
        traces: dict[str, list] = {}
        for st in rollout(env, policy, index, _W["privileged"], cfg["fresh_scene"]):
            pose = st.info["agent_pose"][0].cpu().numpy()
            poses.append([float(v) for v in pose[:3]])
            if st.action is None:
                ep = u.current_episode
                goal = st.info["goal_position"][0].cpu().numpy()
                recorded = _recorded(u, st.info)
                traces = {m.key: [] for _, m, _ in recorded if m.at != "end"}
                traces["positions"], traces["headings"] = [], []
                if recorder is not None:
                    recorder.start(ep, goal)
            else:
                if recorder is not None:  # the pose, distance and frame the policy acted on
                    before = st.info_before["agent_pose"][0].cpu().numpy()
                    recorder.step(
                        len(actions),
                        st.action,
                        before,
                        goal,
                        float(st.info_before[DistanceToGoal.uuid]),
                        st.obs_before,
                    )
                actions.append(st.action if isinstance(st.action, int) else [_r4(v) for v in st.action])
            traces["positions"].append([_r4(pose[0]), _r4(pose[1])])
            traces["headings"].append(_r4(pose[2]))
            for name, m, cls in recorded:
                if m.at == "trace":
                    v = _value(_first(st.info[name]), cls.dtype)
                    traces[m.key].append(_r4(v) if isinstance(v, float) else v)
                elif m.at in ("count", "steps") and st.action is not None and bool(st.info[name]):
                    traces[m.key].append(len(actions))
            info, trunc = st.info, st.truncated
        k = len(ep["goals"])
        rec = {}
        for name, m, cls in recorded:
            if m.at == "end":
                v = _first(info[name])
                rec[m.key] = [_value(x, cls.dtype) for x in v[:k]] if cls.shape else _value(v, cls.dtype)
            elif m.at in ("count", "steps"):
                rec[m.key] = len(traces[m.key]) if m.at == "count" else traces[m.key]
        rec["truncated"] = bool(trunc)
        rec["actions"] = actions
        rec.update((key, traces[key]) for key in ("positions", "headings"))
        rec.update((m.key, traces[m.key]) for _, m, _ in recorded if m.at == "trace")
        if hasattr(policy, "episode_stats"):
            rec["policy_stats"] = policy.episode_stats()
            rec.update(pose_drift(rec["policy_stats"], poses))
        if u.cfg.protocol:
            rec["protocol"] = protocol_meta(ep)
        bad = record_error(rec)
        if bad:  # a failure, never a silent gap in a mean; JSON gets null, not NaN
            rec["error"] = f"invalid record: {bad}"
            rec.update({k: None for k, v in rec.items() if isinstance(v, float) and not math.isfinite(v)})
        if recorder is not None:
            recorder.finish(rec[OUTCOME])
        if cfg.get("handoff_dir") and rec[OUTCOME] and not bad and not u.cfg.protocol:
            rec["handoff"] = handoff_payload(env, info, cfg)  # the driver writes it, and not into the JSONL
    except Exception as e:  # recorded; the run goes on with the next episode
        rec = {"error": f"{type(e).__name__}: {e}"}
        ep = ep or u.source.episodes[index]
        if "protocol" in ep:
            rec["protocol"] = protocol_meta(ep)
    rec.update(
        {
            "method": cfg["method"],
            "env_id": cfg["env_id"],
            "robot": cfg.get("robot", DEFAULT_ROBOT),
            "noise": cfg.get("noise", "ideal"),
            "split": cfg["split"],
            "index": index,
            "scene_id": ep["scene_id"],
            "episode_id": ep["episode_id"],
            "object_category": ep["object_category"],
            "object_id": ep["object_id"],
            "difficulty": ep["info"]["difficulty"],
            "geodesic_distance": ep["info"]["geodesic_distance"],
            "goal": ep["goals"][0]["position"][:2],
            "start": ep["start_position"][:2],
            "wall_time_s": round(time.perf_counter() - t0, 3),
        }
    )
    return rec


def protocol_meta(ep: dict) -> dict:
    """What a record keeps of a protocol episode: the protocol, K, the route length L, the relations needed
    and every goal in visit order."""
    p = ep["protocol"]
    return {
        "id": p["id"],
        "k": p["k"],
        "route_length": p["route_length"],
        "needs_relation": p["needs_relation"],
        "goals": [g["position"][:2] for g in ep["goals"]],
    }


def pose_drift(stats: dict, poses: list) -> dict:
    """``pose_drift`` and ``pose_drift_max``: the planar distance (m) between the pose a policy estimated
    at its last step, and at its worst, and the true pose it acted from (``info["agent_pose"]``, in
    ``poses`` from the reset on). Estimates in the episode frame (``pose_frame`` "episode": origin at
    the start pose, x along the start heading) are put in the world with the start pose. Empty when the
    policy reports no ``pose_estimates``."""
    est = stats.get("pose_estimates") or []
    if not est:
        return {}
    x0, y0, yaw0 = poses[0]
    c, s = math.cos(yaw0), math.sin(yaw0)
    drift = []
    for (x, y, *_), (tx, ty, *_) in zip(est, poses):
        if stats.get("pose_frame") == "episode":
            x, y = x0 + c * x - s * y, y0 + s * x + c * y
        drift.append(math.hypot(x - tx, y - ty))
    return {"pose_drift": round(drift[-1], 4), "pose_drift_max": round(max(drift), 4)}


# --- driver --------------------------------------------------------------------------------------
def evaluate(cfg: EvalConfig, progress: bool = True, echo=print) -> dict:
    """Run (or resume) a method on a split; returns the summary (also written to summary.json).

    Raises ``LockedError`` at once when another process is writing the same run folder."""
    spec = method_spec(cfg.method, cfg.method_kwargs)
    if spec.preflight:
        spec.preflight(**cfg.method_kwargs)
    if cfg.record_dir and spec.env_kwargs.get("control_mode") == "continuous":
        raise BioVLNError(
            f"the recorder stores the discrete actions of the appendix; '{cfg.method}' acts continuously",
            field="record_dir",
            fix="record a discrete-action method (ppo, a2c, frontier, ...)",
        )
    if cfg.record_dir and _protocol_env(cfg.env_id):
        raise BioVLNError(
            "the recorder stores single-goal trajectories; protocol episodes have K goals",
            field="record_dir",
            fix="record a single-goal run, or evaluate the protocol method without --record",
        )
    if cfg.handoff_dir and _protocol_env(cfg.env_id):
        raise BioVLNError(
            "a hand-off is one goal's final pose; protocol episodes have K goals",
            field="handoff_dir",
            fix="export hand-offs of a single-goal run, or evaluate the protocol method without "
            "--export-handoff",
        )
    obs_mode = spec.obs_mode_under(resolve_noise(cfg.noise).gps_compass)
    if cfg.record_dir and cfg.record_mode == "full" and obs_mode == "state":
        raise BioVLNError(
            f"'{cfg.method}' runs on state observations: there are no frames to record",
            field="record_mode",
            fix="use --record-mode trace",
        )
    with exclusive_lock(
        cfg.run_dir / LOCK_FILE,
        "writing this results folder",
        fix="wait for it to finish, or stop it (`kill {pid}`; running this again resumes), "
        "or write elsewhere (--out or --name)",
    ):
        return _evaluate_locked(cfg, obs_mode, progress, echo)


def _evaluate_locked(cfg: EvalConfig, obs_mode: str, progress: bool, echo) -> dict:
    """``evaluate``'s work, run while holding the run folder's lock; ``obs_mode``: what the method reads
    under ``cfg``'s noise preset (:meth:`MethodSpec.obs_mode_under`), for the workers' env."""
    from tqdm import tqdm

    from biovln_ms.splits import dataset_root
    from biovln_ms.episodes.source import DatasetEpisodes

    root = dataset_root(cfg.dataset, cfg.robot)
    source = DatasetEpisodes(cfg.split, root, cfg.robot)
    episodes = source.episodes[: cfg.max_episodes] if cfg.max_episodes else source.episodes
    if any("protocol" in e for e in episodes[:1]) != _protocol_env(cfg.env_id):
        kind = "protocol (multi-goal)" if _protocol_env(cfg.env_id) else "single-goal"
        raise BioVLNError(
            f"method '{cfg.method}' runs {kind} episodes on {cfg.env_id}; split '{cfg.split}' holds "
            "the other kind",
            field="split",
            fix="run the protocol_* methods on the protocol_* splits, the others on the single-goal ones",
        )
    run_dir = cfg.run_dir
    manifest = write_manifest(cfg, root)
    path = run_dir / "episodes.jsonl"
    raw = load_records(path)
    previous, dups = unique_records(raw)
    check_resume(cfg, manifest, previous)
    wanted = {episode_key(e) for e in episodes}
    retry = {episode_key(r) for r in previous if record_error(r) and episode_key(r) in wanted}
    previous = [r for r in previous if episode_key(r) not in retry]
    if len(previous) != len(raw):  # duplicates dropped, errored episodes to run again
        atomic_write_text(path, "".join(json.dumps(r, separators=(",", ":")) + "\n" for r in previous))
    if dups:
        echo(
            f"repaired {path}: {len(dups)} episodes had more than one record (two writers at once, "
            f"before the lock): {_name_keys(dups)}; kept the first record of each"
        )
    done = {episode_key(r) for r in previous}
    todo = [i for i, e in enumerate(episodes) if episode_key(e) not in done]
    if done:
        again = f" ({len(retry)} that errored run again)" if retry else ""
        echo(f"resuming {cfg.run_name} on {cfg.split}: {len(done)} done, {len(todo)} to go{again}")
    workers = max(1, min(cfg.workers or os.cpu_count() or 1, len(todo) or 1))
    wcfg = {**asdict(cfg), "obs_mode": obs_mode}  # the workers' env observes what the method reads
    bar = tqdm(
        total=len(episodes), initial=len(done), desc=f"{cfg.run_name} {cfg.split}", disable=not progress
    )
    n_ok = sum(1 for r in previous if r.get("success") and not record_error(r))
    try:
        with open(path, "a") as f:

            def write(rec):
                nonlocal n_ok
                handoff = rec.pop("handoff", None)
                if handoff is not None:
                    write_handoff(cfg.handoff_dir, cfg.run_name, handoff)
                f.write(json.dumps(rec, separators=(",", ":")) + "\n")
                f.flush()
                os.fsync(f.fileno())
                n_ok += bool(rec.get("success")) and not rec.get("error")
                bar.update(1)
                bar.set_postfix(SR=f"{100 * n_ok / max(bar.n, 1):.1f}%")

            if todo and workers == 1:  # (a complete run only rewrites its summary: no env is built)
                _init_worker(wcfg)
                try:
                    for i in todo:
                        write(_run(i))
                finally:
                    _W["env"].close()
                    _W.clear()
            elif todo and cfg.ray_address:
                _run_on_ray(cfg.ray_address, wcfg, todo, workers, write)
            elif todo:
                _run_on_pool(wcfg, todo, workers, write)
    finally:  # a failure's one line starts on a line of its own
        bar.close()
    return write_summary(cfg, len(episodes))


def _keep_config(cfg: dict) -> None:
    """Pool initializer: keep the run's config. The worker's first episode builds its env and policy
    (:func:`_run_pooled`), so that a failure there reaches the driver as that episode's exception."""
    _W["config"] = cfg


def _run_pooled(index: int) -> dict:
    """One episode in a pool worker, the worker's env and policy built first if not yet."""
    if "env" not in _W:
        _init_worker(_W["config"])
    return _run(index)


def _run_on_pool(wcfg: dict, todo: list[int], workers: int, write) -> None:
    """Run episodes in ``workers`` spawned processes, writing each record as it arrives.

    A worker that cannot start (a bad checkpoint, no renderer) raises its error here, once, and the run
    stops: ``multiprocessing.Pool`` would restart a failing initializer without end, and wait forever
    on a worker that died (a crash, the OOM killer), which ``ProcessPoolExecutor`` reports instead."""
    import multiprocessing as mp
    from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
    from concurrent.futures.process import BrokenProcessPool

    pool = ProcessPoolExecutor(
        workers, mp_context=mp.get_context("spawn"), initializer=_keep_config, initargs=(wcfg,)
    )
    restore, finished = exit_on_sigterm(), False
    try:
        pending = {pool.submit(_run_pooled, i) for i in todo}
        while pending:
            done, pending = wait(pending, return_when=FIRST_COMPLETED)
            for fut in done:
                write(fut.result())
        finished = True
    except BrokenProcessPool:
        raise BioVLNError(
            "an evaluation worker process died (crashed, or killed for memory)",
            field="workers",
            fix="run again to resume; with --workers 1 its error shows, fewer workers need less memory",
        ) from None
    finally:
        try:
            if finished:  # every episode ran: the workers end on their own
                pool.shutdown(wait=True)
            else:
                stop_process_pool(pool)
        finally:
            restore()


class EpisodeRunner:
    """A Ray actor: one env and one policy, running episodes by index (as a pool worker does)."""

    def __init__(self, wcfg: dict) -> None:
        _init_worker(wcfg)

    def run(self, index: int) -> dict:
        return _run(index)


def _run_on_ray(address: str, wcfg: dict, todo: list[int], workers: int, write) -> None:
    """Run episodes on Ray actors; results are written as they arrive, so resume works as with a pool."""
    ray, started = start_ray(address, workers)
    actors = []
    try:
        runner = ray.remote(num_cpus=1)(EpisodeRunner)
        actors += [runner.remote(wcfg) for _ in range(workers)]
        queue = list(todo)
        pending = {}
        for actor in actors:
            if queue:
                pending[actor.run.remote(queue.pop(0))] = actor
        while pending:
            (ref,), _ = ray.wait(list(pending), num_returns=1)
            actor = pending.pop(ref)
            write(ray.get(ref))
            if queue:
                pending[actor.run.remote(queue.pop(0))] = actor
    finally:
        stop_ray_work(ray, actors=actors)  # done, an error, ^C or SIGTERM: none left on a joined cluster
        if started:
            ray.shutdown()


MANIFEST = "manifest.json"  # in a run's split folder: who the run is (the report reads it)


def dataset_digest(root: Path, split: str) -> str:
    """SHA-256 over the dataset's manifest and the split's files (names and bytes)."""
    h = hashlib.sha256()
    files = [root / "manifest.json", *sorted(p for p in (root / split).rglob("*") if p.is_file())]
    for f in files:
        if f.is_file():
            h.update(str(f.relative_to(root)).encode() + b"\0" + f.read_bytes())
    return h.hexdigest()


def write_manifest(cfg: EvalConfig, root: Path) -> dict:
    """``manifest.json`` of the run: method, env, robot, noise preset, split, the dataset's digest, the
    package's version and commit, and the arguments. A resumed run keeps its first one."""
    path = cfg.run_dir / MANIFEST
    if path.exists():
        return json.loads(path.read_text())
    try:
        version = metadata.version("biovln-ms")
    except metadata.PackageNotFoundError:
        version = None
    manifest = {
        "method": cfg.method,
        "label": method_spec(cfg.method).label,
        "env_id": cfg.env_id,
        "robot": cfg.robot,
        "noise": cfg.noise,
        "split": cfg.split,
        "dataset": str(root),
        "dataset_sha256": dataset_digest(Path(root), cfg.split),
        "package_version": version,
        "commit": source_commit(),
        "arguments": {
            "method_kwargs": cfg.method_kwargs,
            "camera": list(cfg.camera),
            "max_episodes": cfg.max_episodes,
            "fresh_scene": cfg.fresh_scene,
            "plugins": cfg.plugins,
            "record_mode": cfg.record_mode if cfg.record_dir else None,
        },
    }
    atomic_write_text(path, json.dumps(manifest, indent=1, sort_keys=True) + "\n")
    return manifest


def check_resume(cfg: EvalConfig, manifest: dict, previous: list[dict]) -> None:
    """A run folder is resumed only by the method that made it: the same method, label, noise, robot, env
    and method options (a folder of a method whose default changed, e.g. ``vlfm`` before its learned
    detector, is refused: its records' ``policy_stats.label`` names the other). One-line error."""
    if not previous:
        return
    label = method_spec(cfg.method).label
    same = ("method", "noise", "robot", "env_id")
    made = {k: manifest.get(k) for k in same} | {
        "method options": manifest.get("arguments", {}).get("method_kwargs", cfg.method_kwargs),
        "label": manifest.get("label", label),
    }
    now = {k: getattr(cfg, k) for k in same} | {"method options": cfg.method_kwargs, "label": label}
    if not cfg.method_kwargs:  # a folder from before labels were kept: its records may name their maker
        seen = {r["policy_stats"]["label"] for r in previous if "label" in r.get("policy_stats", {})}
        if len(seen) == 1 and made["label"] == label:
            made["label"] = seen.pop()
    differs = [k for k in now if made[k] != now[k]]
    if differs:
        k = differs[0]
        raise BioVLNError(
            f"{cfg.run_dir} holds {len(previous)} episodes of another run ({k} {made[k]!r}, not {now[k]!r})",
            field="name",
            fix="give another --name or --out; or resume it with the method and options that made it",
        )


def read_manifest(run_dir: Path, records: list[dict]) -> dict:
    """Who a run is: its ``manifest.json``, else (a run folder without one) its records' own fields."""
    path = Path(run_dir) / MANIFEST
    if path.is_file():
        return json.loads(path.read_text())
    r = records[0] if records else {}
    keys = ("method", "env_id", "robot", "noise", "split")
    return {k: r.get(k) for k in keys} | {
        "robot": r.get("robot") or DEFAULT_ROBOT,
        "noise": r.get("noise") or "ideal",
    }


def write_summary(cfg: EvalConfig, expected: int) -> dict:
    """Aggregate the run's records (one per episode, errored ones as failures) into summary.json."""
    records, _ = unique_records(load_records(cfg.run_dir / "episodes.jsonl"))
    aggregates = aggregate_all(records)
    summary = {
        "method": cfg.method,
        "env_id": cfg.env_id,
        "split": cfg.split,
        "run": cfg.run_name,
        "expected_episodes": expected,
        "errors": aggregates["overall"]["errors"],
        **aggregates,
        "failed_episodes": [
            {"key": episode_key(r), "error": record_error(r)} for r in records if record_error(r)
        ],
    }
    atomic_write_text(
        cfg.run_dir / "summary.json", json.dumps(_finite(summary), indent=1, sort_keys=True) + "\n"
    )
    return summary


def _finite(obj):
    if isinstance(obj, float):
        return None if not math.isfinite(obj) else round(obj, 6)
    if isinstance(obj, dict):
        return {k: _finite(v) for k, v in obj.items()}
    if isinstance(obj, list):
        return [_finite(v) for v in obj]
    return obj
