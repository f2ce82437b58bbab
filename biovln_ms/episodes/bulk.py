"""Training data at scale: one custom split of N generated scenes x K episodes, built in parallel (a process
pool, or Ray), resumable and deterministic.

``build_training_split`` writes a dataset folder of :mod:`biovln_ms.episodes.dataset`'s format holding one
split: scene ``i`` is generated from the ``i``-th usable seed from ``first_seed`` up (``generate_scene``), and
its episodes are drawn by ``SingleGoalEpisodes`` from the split's seed, as ``write_dataset`` draws them. A
seed is unusable when ``held_out`` lists it for the template (the benchmark scenes never enter a training
split; the caller names them: this model layer cannot see the paper's splits) or when it gives no scene
(``GenerationError``) or no episodes (``EpisodeError``). The result depends on the arguments only, never on
the worker count or the order work finishes in: the split takes the first ``scenes`` usable seeds.

Each scene's result is a shard, written atomically into ``.<name>.shards`` beside the output (locked while a
build runs); a killed build, run again with the same arguments, keeps its finished shards. When every scene
is there, the dataset is assembled in a temporary sibling folder and renamed into place (as
``write_dataset`` does), and the shards are removed. Shards of other arguments (another template, first
seed, episode count, split name, robot, catalog or generator version) are discarded.
"""

from __future__ import annotations

import base64
import hashlib
import json
import os
import re
import shutil
from collections.abc import Callable, Collection, Iterator, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

from biovln_ms.catalog import load_catalog
from biovln_ms.constants import SCENE_GENERATOR_VERSION
from biovln_ms.episodes.dataset import (
    EPISODE_GENERATOR_VERSION,
    MAX_EPISODES_PER_SPLIT,
    DatasetError,
    sha256,
)
from biovln_ms.episodes.generator import EpisodeError
from biovln_ms.episodes.samplers import SceneSamplers, SingleGoalEpisodes
from biovln_ms.episodes.writer import gz_json, new_manifest, partial_folder, put_in_place, stable_split_seed
from biovln_ms.cluster import check_address, exit_on_sigterm, start_ray, stop_process_pool, stop_ray_work
from biovln_ms.errors import BioVLNError
from biovln_ms.io_utils import atomic_write_bytes, exclusive_lock
from biovln_ms.limits import ID_CHARS, ID_RULE, MAX_ID_LENGTH, MAX_WORKERS
from biovln_ms.plugins import load_plugins, loaded_plugins
from biovln_ms.robot_specs import DEFAULT_ROBOT, robot_spec
from biovln_ms.scene.generator import GenerationError, generate_scene
from biovln_ms.scene.templates import Template, get_template

#: scenes of one split: its manifest (about 400 bytes a scene) stays well under the loader's 16 MiB
MAX_SCENES = 20_000
#: episodes per scene (the episodes of a split are bounded too: ``MAX_EPISODES_PER_SPLIT``)
MAX_EPISODES_PER_SCENE = 1_000
#: the first seed: a 32-bit unsigned integer
MAX_SEED = 2**32 - 1
#: seeds that gave no scene or no episodes, beyond which a build stops (the template rarely works)
MAX_UNUSABLE = 1_000
SHARD_FORMAT = 1


class BulkError(BioVLNError):
    """A bulk build's arguments are out of bounds, or its workers cannot run."""


@dataclass(frozen=True)
class _Job:
    """What a worker needs for one seed (picklable: a spawned process or a Ray task gets it)."""

    template: Template
    seed: int
    episodes: int
    split_seed: int
    radius: float
    plugins: tuple[str, ...] = ()


def check_request(
    scenes: object,
    episodes_per_scene: object,
    first_seed: object = 0,
    workers: object = 1,
    split: object = "train",
    ray_address: object = None,
) -> None:
    """Refuse, in one line naming the argument and the fix, a bulk build's argument out of bounds."""

    def whole(v: object) -> bool:
        return isinstance(v, int) and not isinstance(v, bool)

    checks = (
        ("scenes", scenes, 1, MAX_SCENES),
        ("episodes_per_scene", episodes_per_scene, 1, MAX_EPISODES_PER_SCENE),
        ("seed", first_seed, 0, MAX_SEED),
        ("workers", workers, 1, MAX_WORKERS),
    )
    for name, v, lo, hi in checks:
        if not whole(v) or not lo <= v <= hi:
            raise BulkError(
                f"{v!r} is not a whole number from {lo:,} to {hi:,}",
                field=name,
                fix=f"give {name.replace('_', '-')} from {lo:,} to {hi:,}"
                + ("; make several splits for more" if name in ("scenes", "episodes_per_scene") else ""),
            )
    if scenes * episodes_per_scene > MAX_EPISODES_PER_SPLIT:
        raise BulkError(
            f"{scenes:,} scenes x {episodes_per_scene:,} episodes is over the limit of "
            f"{MAX_EPISODES_PER_SPLIT:,} episodes a split",
            field="scenes",
            fix="make several splits (another --split name and --seed each)",
        )
    if not isinstance(split, str) or len(split) > MAX_ID_LENGTH or not re.fullmatch(ID_CHARS, split):
        raise BulkError(f"{str(split)[:60]!r} is not an id", field="split", fix=f"use {ID_RULE}")
    if ray_address is not None:
        check_address(ray_address)


def usable_seeds(template: str, first_seed: int, held_out: Mapping[str, Collection[int]]) -> Iterator[int]:
    """The seeds a bulk build of ``template`` tries, in order: ``first_seed`` up, without ``held_out``'s."""
    skip = held_out.get(template, ())
    seed = first_seed
    while True:
        if seed not in skip:
            yield seed
        seed += 1


_PLUGINS_LOADED: set[tuple[str, ...]] = set()


def make_shard(job: _Job) -> dict:
    """One seed's scene and episodes: ``{"seed", "ok": True, "name", "template", "scene", "episodes_gz",
    "episodes", "catalog_sha256"}`` (the scene file's text and the episode file's bytes, exactly as a dataset
    holds them), or ``{"seed", "ok": False, "reason"}`` when the seed gives no scene or no episodes."""
    if job.plugins not in _PLUGINS_LOADED:  # once per process: load_plugins scans the entry points
        load_plugins(list(job.plugins))
        _PLUGINS_LOADED.add(job.plugins)
    try:
        spec = generate_scene(job.template, job.seed, robot_radius=job.radius)
        eps = SingleGoalEpisodes().draw(SceneSamplers(), spec, job.episodes, job.split_seed)
    except (GenerationError, EpisodeError) as e:
        return {"seed": job.seed, "ok": False, "reason": str(e)}
    return {
        "seed": job.seed,
        "ok": True,
        "name": spec.name,
        "template": spec.template,
        "scene": spec.to_json(),
        "episodes_gz": gz_json({"episodes": eps}),
        "episodes": len(eps),
        "catalog_sha256": spec.catalog_sha256,
    }


# --- where work runs: in this process, a spawned process pool, or Ray ---------------------------------------
def _backend(workers: int, ray_address: str | None):
    """Where the shards are made: Ray tasks, spawned processes, or this process (one worker)."""
    if ray_address is not None:
        return _Ray(ray_address, workers)
    return _Inline() if workers == 1 else _Pool(workers)


class _Inline:
    """Runs each job when it is submitted (one worker: no process to start)."""

    def __init__(self) -> None:
        self._done: list[dict] = []

    def submit(self, job: _Job) -> None:
        self._done.append(make_shard(job))

    def next_result(self) -> dict:
        return self._done.pop(0)

    def close(self) -> None:
        pass


class _Pool:
    """A ``ProcessPoolExecutor`` of spawned processes (no fork of the caller's threads and locks)."""

    def __init__(self, workers: int) -> None:
        import multiprocessing as mp
        from concurrent.futures import ProcessPoolExecutor

        self._pool = ProcessPoolExecutor(workers, mp_context=mp.get_context("spawn"))
        self._pending: set = set()

    def submit(self, job: _Job) -> None:
        self._pending.add(self._pool.submit(make_shard, job))

    def next_result(self) -> dict:
        from concurrent.futures import FIRST_COMPLETED, wait
        from concurrent.futures.process import BrokenProcessPool

        done, _ = wait(self._pending, return_when=FIRST_COMPLETED)
        fut = min(done, key=id)
        self._pending.discard(fut)
        try:
            return fut.result()
        except BrokenProcessPool:
            raise BulkError(
                "a dataset worker process died (crashed, or killed for memory)",
                field="workers",
                fix="run the same command again to resume; fewer workers need less memory",
            ) from None

    def close(self) -> None:
        stop_process_pool(self._pool)


class _Ray:
    """Ray tasks of one CPU each; ``local`` starts a local instance of ``workers`` CPUs, another address joins
    a running cluster (whose nodes need this package, its catalog and the plugins)."""

    def __init__(self, address: str, workers: int) -> None:
        ray, self._started = start_ray(address, workers)
        self._ray = ray
        self._task = ray.remote(num_cpus=1)(make_shard)
        self._pending: list = []

    def submit(self, job: _Job) -> None:
        self._pending.append(self._task.remote(job))

    def next_result(self) -> dict:
        (ref,), _ = self._ray.wait(self._pending, num_returns=1)
        self._pending.remove(ref)
        return self._ray.get(ref)

    def close(self) -> None:
        stop_ray_work(self._ray, tasks=self._pending)  # after an error, ^C or SIGTERM: none left running
        self._pending.clear()
        if self._started:
            self._ray.shutdown()


# --- the build --------------------------------------------------------------------------------------------
def shards_dir(out: str | Path) -> Path:
    """Where a bulk build of dataset folder ``out`` keeps its finished scenes until it is assembled."""
    out = Path(out)
    return out.parent / f".{out.name}.shards"


def _plan(t: Template, first_seed: int, k: int, split: str, robot: str, radius: float) -> dict:
    """What a shard depends on: shards of another plan are not reused."""
    return {
        "shard_format": SHARD_FORMAT,
        "template": t.name,
        "template_sha256": sha256(t.model_dump_json().encode()),
        "first_seed": first_seed,
        "episodes_per_scene": k,
        "split": split,
        "robot": robot,
        "agent_radius": radius,
        "catalog_sha256": load_catalog().sha256,
        "scene_generator_version": SCENE_GENERATOR_VERSION,
        "episode_generator_version": EPISODE_GENERATOR_VERSION,
    }


def _save_shard(folder: Path, result: dict, plan_id: str) -> dict:
    """Write ``result`` as ``<seed>.json``; returns what the build keeps of it in memory."""
    record = {k: v for k, v in result.items() if k != "episodes_gz"}
    record["plan"] = plan_id
    if result["ok"]:
        record["episodes_gz"] = base64.b64encode(result["episodes_gz"]).decode()
    atomic_write_bytes(folder / f"{result['seed']}.json", json.dumps(record, sort_keys=True).encode())
    return {"ok": result["ok"], "name": result.get("name"), "reason": result.get("reason")}


def _read_shards(folder: Path, plan_id: str) -> dict[int, dict]:
    """The finished shards of ``plan_id`` by seed; an unreadable one (a disk that lost it) is redone."""
    found = {}
    for p in folder.glob("*.json"):
        if not p.stem.isdigit():
            continue
        try:
            rec = json.loads(p.read_bytes())
            if rec["plan"] != plan_id or rec["seed"] != int(p.stem):
                raise ValueError("another plan")
            if rec["ok"]:
                base64.b64decode(rec["episodes_gz"], validate=True)
                if not all(isinstance(rec[k], str) for k in ("scene", "name", "template")):
                    raise ValueError("not a shard")
        except (OSError, ValueError, KeyError, TypeError):
            p.unlink(missing_ok=True)
            continue
        found[rec["seed"]] = {"ok": rec["ok"], "name": rec.get("name"), "reason": rec.get("reason")}
    return found


def _open_shards(folder: Path, plan: dict, echo: Callable[[str], None]) -> str:
    """Keep ``folder``'s shards when they are of ``plan`` (a resumed build), else empty it; the plan's id."""
    plan_text = json.dumps(plan, sort_keys=True)
    plan_id = hashlib.sha256(plan_text.encode()).hexdigest()[:16]
    path = folder / "plan.json"
    try:
        same = json.loads(path.read_text()) == plan
    except (OSError, ValueError):
        same = False
    if not same:
        stale = [p for p in folder.iterdir() if p.name != "lock"]
        if any(p.name != "plan.json" for p in stale):
            echo(f"[biovln-ms] {folder}: shards of other arguments, discarded")
        for p in stale:
            shutil.rmtree(p) if p.is_dir() and not p.is_symlink() else p.unlink()
        atomic_write_bytes(path, (plan_text + "\n").encode())
    return plan_id


def build_training_split(
    out: str | Path,
    template: str | Template,
    scenes: int,
    episodes_per_scene: int,
    *,
    held_out: Mapping[str, Collection[int]],
    first_seed: int = 0,
    workers: int = 1,
    ray_address: str | None = None,
    split: str = "train",
    robot: str = DEFAULT_ROBOT,
    progress: bool = True,
    plugins: Sequence[str] | None = None,
    echo: Callable[[str], None] = lambda _: None,
) -> dict:
    """Build dataset folder ``out`` holding split ``split``: ``scenes`` scenes of ``template`` (the first
    usable seeds from ``first_seed`` up; ``held_out``: template name -> seeds never used) x
    ``episodes_per_scene`` single-goal episodes, for ``robot``; returns the manifest.

    ``workers`` processes (1: this process), or ``workers`` Ray tasks at a time with ``ray_address``. The
    bytes written depend on the arguments only. A killed build run again resumes from its shards
    (``shards_dir``). ``plugins`` (default: those loaded here) are imported by every worker first."""
    check_request(scenes, episodes_per_scene, first_seed, workers, split, ray_address)
    t = get_template(template)
    if t.scene_name(0) == t.scene_name(1):
        raise BulkError(
            f"template '{t.name}' names every scene '{t.scene_name(0)}'",
            field="name_pattern",
            fix="put {seed} in the template's name_pattern",
        )
    radius = robot_spec(robot, "robot").footprint_radius
    plan = _plan(t, first_seed, episodes_per_scene, split, robot, radius)
    out = Path(out)
    folder = shards_dir(out)
    folder.mkdir(parents=True, exist_ok=True)
    with exclusive_lock(folder / "lock", f"building {out}", "wait for process {pid} to end, then run again"):
        plan_id = _open_shards(folder, plan, echo)
        found = _read_shards(folder, plan_id)
        plugs = tuple(loaded_plugins() if plugins is None else plugins)
        job = _Job(t, 0, episodes_per_scene, stable_split_seed(split), radius, plugs)
        try:
            chosen, unusable = _run(
                t, scenes, first_seed, held_out, job, found, folder, plan_id, workers, ray_address, progress
            )
        except BaseException:
            if not any(p.stem.isdigit() for p in folder.glob("*.json")):  # nothing to resume (Ray refused)
                shutil.rmtree(folder, ignore_errors=True)
            raise
        skipped = sum(1 for s in held_out.get(t.name, ()) if first_seed <= s <= chosen[-1])
        description = (
            f"{scenes} scenes of '{t.name}' from seed {first_seed} ({skipped} held-out and {unusable} "
            f"unusable seeds skipped), {episodes_per_scene} episodes per scene"
        )
        manifest = _assemble(out, folder, chosen, split, description, robot, radius, plan["catalog_sha256"])
        shutil.rmtree(folder, ignore_errors=True)  # under the lock: a build waiting for it starts afresh
    return manifest


def _run(
    t: Template,
    n: int,
    first_seed: int,
    held_out: Mapping[str, Collection[int]],
    job: _Job,
    found: dict[int, dict],
    folder: Path,
    plan_id: str,
    workers: int,
    ray_address: str | None,
    progress: bool,
) -> tuple[list[int], int]:
    """Make the missing shards until the first ``n`` usable seeds are known; returns them and the number of
    unusable seeds among those tried before the last of them.

    Seeds are tried in order, and another one only while the usable and running ones are fewer than ``n``: the
    seeds chosen are the first ``n`` usable ones, however the work is spread and whatever order it ends in."""
    from dataclasses import replace

    from tqdm import tqdm

    order: list[int] = []
    seeds = usable_seeds(t.name, first_seed, held_out)
    running: set[int] = set()
    ok = unusable = 0
    reason = None
    bar = tqdm(total=n, desc=f"{t.name} scenes", unit="scene", disable=not progress)
    backend = None  # started at the first seed without a shard: a finished build starts no worker
    capacity = 1 if ray_address is None and workers == 1 else 4 * workers  # seeds in flight

    def count(seed: int) -> None:
        nonlocal ok, unusable, reason
        if found[seed]["ok"]:
            ok += 1
            bar.update(1)
        else:
            unusable += 1
            reason = found[seed]["reason"]
        if unusable > MAX_UNUSABLE:
            raise BulkError(
                f"{unusable} seeds of template '{t.name}' from {first_seed} up gave no scene or no episodes; "
                f"the last: {reason}",
                field="template",
                fix="check the template's slots and rules (biovln-ms scene generate), or use another",
            )

    restore = exit_on_sigterm()  # a kill ends the worker processes too (backend.close below)
    try:
        while True:
            while ok + len(running) < n and len(running) < capacity:
                seed = next(seeds)
                order.append(seed)
                if seed in found:  # a finished shard of this plan (a resumed build)
                    count(seed)
                else:
                    if backend is None:
                        backend = _backend(workers, ray_address)
                    backend.submit(replace(job, seed=seed))
                    running.add(seed)
            if not running:
                break
            result = backend.next_result()
            if result["ok"] and result["catalog_sha256"] != load_catalog().sha256:
                raise BulkError(
                    "a worker generated its scene from another instrument catalog",
                    field="catalog_sha256",
                    fix="install the same biovln-ms, catalog and plugins on every Ray node",
                )
            found[result["seed"]] = _save_shard(folder, result, plan_id)
            running.discard(result["seed"])
            count(result["seed"])
    finally:
        try:
            if backend is not None:
                backend.close()
            bar.close()
        finally:
            restore()
    chosen = [s for s in order if found[s]["ok"]][:n]
    return chosen, sum(1 for s in order if not found[s]["ok"] and s < chosen[-1])


def _assemble(
    out: Path,
    folder: Path,
    seeds: list[int],
    split: str,
    description: str,
    robot: str,
    radius: float,
    catalog_sha256: str,
) -> dict:
    """Write the dataset of ``seeds``' shards into a locked temporary sibling of ``out`` and rename it into
    place; the manifest is ``write_dataset``'s for a one-split plan of these scenes."""
    tmp, lock = partial_folder(out)
    try:
        (tmp / split / "content").mkdir(parents=True)
        manifest = new_manifest(robot, radius, catalog_sha256)
        entry: dict = {"description": description, "scenes": [], "episodes": 0, "files": {}}
        for seed in seeds:
            rec = json.loads((folder / f"{seed}.json").read_bytes())
            name = rec["name"]
            if name in manifest["scenes"]:
                raise DatasetError(f"seeds give scene '{name}' twice", field="name_pattern")
            data = rec["scene"].encode()
            (tmp / "scenes" / f"{name}.json").write_bytes(data)
            manifest["scenes"][name] = {
                "template": rec["template"],
                "seed": seed,
                "sha256": sha256(data),
                "file": f"scenes/{name}.json",
            }
            blob = base64.b64decode(rec["episodes_gz"])
            rel = f"{split}/content/{name}.json.gz"
            (tmp / rel).write_bytes(blob)
            entry["scenes"].append(name)
            entry["episodes"] += rec["episodes"]
            entry["files"][name] = {"file": rel, "sha256": sha256(blob), "episodes": rec["episodes"]}
        manifest["splits"][split] = entry
        return put_in_place(out, tmp, manifest)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    finally:
        if lock is not None:
            os.close(lock)
