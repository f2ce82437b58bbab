"""Building a dataset (the format is :mod:`biovln_ms.episodes.dataset`'s): what each split holds
(``SplitPlan``: its scenes and the sampler drawing their episodes), and ``write_dataset``, which draws the
episodes, writes the scene specs, the episode files and the manifest into a locked temporary folder and
renames it into place, so a killed build never leaves a dataset that loads."""

from __future__ import annotations

import gzip
import io
import json
import os
import re
import shutil
import time
from dataclasses import dataclass, field
from pathlib import Path

from biovln_ms.catalog import load_catalog
from biovln_ms.constants import SCENE_GENERATOR_VERSION
from biovln_ms.episodes.dataset import DATASET_FORMAT_VERSION, EPISODE_GENERATOR_VERSION, DatasetError, sha256
from biovln_ms.episodes.generator import stable_seed
from biovln_ms.episodes.samplers import Sampler, SceneSamplers, SingleGoalEpisodes
from biovln_ms.robot_specs import DEFAULT_ROBOT, robot_spec
from biovln_ms.scene.spec import SceneSpec

STALE_BUILD_AGE_S = 3600  # an unlocked build folder whose pid runs (reused?) is stale after this


def gz_json(obj) -> bytes:
    """Deterministic gzip of canonical JSON (mtime 0, no file name)."""
    buf = io.BytesIO()
    with gzip.GzipFile(fileobj=buf, mode="wb", mtime=0, filename="") as f:
        f.write(json.dumps(obj, sort_keys=True, separators=(",", ":")).encode())
    return buf.getvalue()


@dataclass
class SplitPlan:
    """What a split holds: (spec, episodes per scene, cross_room) per scene and the sampler drawing them,
    or why it is missing."""

    name: str
    scenes: list[tuple[SceneSpec, int, bool]] = field(default_factory=list)
    missing: str | None = None
    description: str = ""
    view_of: str | None = None  # reuse these scenes' episode files from another split
    sampler: Sampler = field(default_factory=SingleGoalEpisodes)


def _pid_running(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (OverflowError, ValueError):  # not a pid this machine can have
        return False
    except OSError:  # EPERM: it runs, as another user
        return True
    return True


def _lock_folder(path: Path) -> int | None:
    """A descriptor holding an exclusive ``flock`` on folder ``path``, or None if another process holds it.
    The kernel drops the lock when its holder dies, however it dies."""
    import fcntl

    fd = os.open(path, os.O_RDONLY | os.O_DIRECTORY | os.O_CLOEXEC)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError:
        os.close(fd)
        return None
    return fd


def remove_stale_builds(out: str | Path, max_age_s: float = STALE_BUILD_AGE_S) -> list[Path]:
    """Remove the ``.<name>.partial-<pid>`` siblings of dataset folder ``out`` left by killed builds.

    A build folder is stale when no process holds its lock (a running build always does) and either its
    pid is not running on this machine or it was last modified more than ``max_age_s`` ago (the pid was
    reused). A live concurrent build's folder is never removed. Returns the removed folders."""
    out = Path(out)
    prefix = f".{out.name}.partial-"
    try:
        siblings = list(out.parent.iterdir())
    except OSError:
        return []
    removed = []
    for p in siblings:
        pid = p.name[len(prefix) :] if p.name.startswith(prefix) else ""
        if not re.fullmatch(r"[0-9]{1,12}", pid) or int(pid) == os.getpid() or p.is_symlink():
            continue
        try:
            fd = _lock_folder(p)
        except OSError:  # gone meanwhile (renamed into place), or not a folder
            continue
        if fd is None:  # a live build holds it
            continue
        try:
            age = time.time() - os.fstat(fd).st_mtime
            if _pid_running(int(pid)) and age < max_age_s:
                continue
            shutil.rmtree(p, ignore_errors=True)
            removed.append(p)
        finally:
            os.close(fd)
    return removed


def write_dataset(
    out: Path, splits: list[SplitPlan], progress: bool = True, robot: str = DEFAULT_ROBOT
) -> dict:
    """Build every split's episodes for ``robot`` (a ``biovln_ms.robot_specs.ROBOTS`` id: the scenes must have
    been generated for its footprint radius) and write the dataset atomically; returns the manifest.

    Writes into ``.<name>.partial-<pid>`` beside ``out`` (locked while this build runs) and renames it
    into place; first removes what killed builds left there (``remove_stale_builds``)."""
    radius = robot_spec(robot, "robot").footprint_radius
    out = Path(out)
    tmp, lock = partial_folder(out)
    try:
        return _build(out, tmp, splits, progress, robot, radius)
    finally:
        if lock is not None:
            os.close(lock)


def partial_folder(out: Path) -> tuple[Path, int | None]:
    """A fresh ``.<name>.partial-<pid>`` beside ``out`` with its ``scenes/`` folder, and the lock held on it
    while the build runs (close it when done); first removes what killed builds left there."""
    remove_stale_builds(out)
    tmp = out.parent / f".{out.name}.partial-{os.getpid()}"
    if tmp.exists():
        shutil.rmtree(tmp)
    (tmp / "scenes").mkdir(parents=True)
    return tmp, _lock_folder(tmp)


def new_manifest(robot: str, radius: float, catalog_sha256: str) -> dict:
    """A dataset manifest without scenes or splits yet."""
    return {
        "format_version": DATASET_FORMAT_VERSION,
        "robot": robot,
        "agent_radius": radius,
        "catalog_sha256": catalog_sha256,
        "scene_generator_version": SCENE_GENERATOR_VERSION,
        "episode_generator_version": EPISODE_GENERATOR_VERSION,
        "scenes": {},
        "splits": {},
    }


def put_in_place(out: Path, tmp: Path, manifest: dict) -> dict:
    """Write ``manifest`` (complete) into ``tmp``, last, and rename ``tmp`` to ``out`` (an existing ``out``
    goes only once the new one is in place); returns the manifest."""
    manifest["complete"] = True
    (tmp / "manifest.json").write_text(json.dumps(manifest, indent=1, sort_keys=True) + "\n")
    if out.exists():
        old = out.parent / f".{out.name}.old-{os.getpid()}"
        out.rename(old)
        tmp.rename(out)
        shutil.rmtree(old)
    else:
        tmp.rename(out)
    return manifest


def _build(out: Path, tmp: Path, splits: list[SplitPlan], progress: bool, robot: str, radius: float) -> dict:
    """``write_dataset``'s work: every file into ``tmp``, the manifest last, then the rename to ``out``."""
    from tqdm import tqdm

    manifest = new_manifest(robot, radius, load_catalog().sha256)
    scenes = SceneSamplers()  # shared by every split: a scene's geometry is built once
    total = sum(len(s.scenes) for s in splits if not s.view_of)
    bar = tqdm(total=total, desc="dataset scenes", disable=not progress)
    for split in splits:
        entry: dict = {"description": split.description, "scenes": [], "episodes": 0, "files": {}}
        if split.missing:
            entry["missing"] = split.missing
        if split.view_of:
            base = manifest["splits"][split.view_of]
            entry["view_of"] = split.view_of
            for spec, _, _ in split.scenes:
                entry["scenes"].append(spec.name)
                entry["files"][spec.name] = base["files"][spec.name]
                entry["episodes"] += base["files"][spec.name]["episodes"]
            manifest["splits"][split.name] = entry
            continue
        if any(spec.dressing for spec, _, _ in split.scenes):
            entry["dressing"] = True
        for spec, n, cross in split.scenes:
            if spec.robot_radius != radius:
                raise DatasetError(
                    f"scene '{spec.name}' was checked for a {spec.robot_radius} m robot, "
                    f"the dataset is for {robot} ({radius} m)"
                )
            if spec.name not in manifest["scenes"]:
                data = spec.to_json().encode()
                (tmp / "scenes" / f"{spec.name}.json").write_bytes(data)
                manifest["scenes"][spec.name] = {
                    "template": spec.template,
                    "seed": spec.seed,
                    "sha256": sha256(data),
                    "file": f"scenes/{spec.name}.json",
                }
                if spec.dressing:  # the generator option, recorded only when on
                    manifest["scenes"][spec.name]["dressing"] = True
            eps = split.sampler.draw(scenes, spec, n, stable_split_seed(split.name), cross_room=cross)
            blob = gz_json({"episodes": eps})
            rel = f"{split.name}/content/{spec.name}.json.gz"
            (tmp / rel).parent.mkdir(parents=True, exist_ok=True)
            (tmp / rel).write_bytes(blob)
            entry["scenes"].append(spec.name)
            entry["episodes"] += len(eps)
            entry["files"][spec.name] = {"file": rel, "sha256": sha256(blob), "episodes": len(eps)}
            bar.update(1)
        manifest["splits"][split.name] = entry
    bar.close()
    return put_in_place(out, tmp, manifest)


def stable_split_seed(name: str) -> int:
    return stable_seed("split", name)
