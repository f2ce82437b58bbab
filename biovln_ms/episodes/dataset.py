"""The benchmark datasets: Habitat-style ``json.gz`` per scene plus a validated manifest.

Layout of a dataset folder::

    manifest.json                   splits, agent radius, catalog hash, generator versions, file hashes
    scenes/<scene>.json             the scene specs
    <split>/content/<scene>.json.gz {"episodes": [...]} per scene

A build writes into a sibling temporary folder and renames it into place at the end, so a killed
build never leaves a dataset that loads. Loading refuses a dataset made for another agent radius or
catalog (Habitat's NaN-SPL trap) and any file whose hash does not match the manifest.
"""

from __future__ import annotations

import gzip
import hashlib
import io
import json
import os
import shutil
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path
from typing import Iterator

from biovln_ms.catalog import load_catalog
from biovln_ms.constants import ROBOT_RADIUS, SCENE_GENERATOR_VERSION
from biovln_ms.errors import BioVLNError
from biovln_ms.scene.spec import SceneSpec, load_spec

DATASET_FORMAT_VERSION = 2  # 2: the lsat_target split and marker goals (goal_source)
EPISODE_GENERATOR_VERSION = 1


class DatasetError(BioVLNError):
    """A missing, incomplete, corrupt or mismatching dataset."""


def gz_json(obj) -> bytes:
    """Deterministic gzip of canonical JSON (mtime 0, no file name)."""
    buf = io.BytesIO()
    with gzip.GzipFile(fileobj=buf, mode="wb", mtime=0, filename="") as f:
        f.write(json.dumps(obj, sort_keys=True, separators=(",", ":")).encode())
    return buf.getvalue()


def sha256(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


@dataclass
class SplitPlan:
    """What a split holds: (spec, episodes per scene, cross_room) per scene, or why it is missing."""

    name: str
    scenes: list[tuple[SceneSpec, int, bool]] = field(default_factory=list)
    missing: str | None = None
    description: str = ""
    view_of: str | None = None  # reuse these scenes' episode files from another split


def write_dataset(
    out: Path, splits: list[SplitPlan], progress: bool = True, radius: float = ROBOT_RADIUS
) -> dict:
    """Build every split's episodes and write the dataset atomically; returns the manifest."""
    from tqdm import tqdm

    from biovln_ms.episodes.generator import EpisodeSampler

    out = Path(out)
    tmp = out.parent / f".{out.name}.partial-{os.getpid()}"
    if tmp.exists():
        shutil.rmtree(tmp)
    (tmp / "scenes").mkdir(parents=True)
    cat = load_catalog()
    manifest: dict = {
        "format_version": DATASET_FORMAT_VERSION,
        "agent_radius": radius,
        "catalog_sha256": cat.sha256,
        "scene_generator_version": SCENE_GENERATOR_VERSION,
        "episode_generator_version": EPISODE_GENERATOR_VERSION,
        "scenes": {},
        "splits": {},
    }
    samplers: dict[str, EpisodeSampler] = {}
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
        for spec, n, cross in split.scenes:
            if spec.robot_radius != radius:
                raise DatasetError(
                    f"scene '{spec.name}' was checked for a {spec.robot_radius} m robot, "
                    f"the dataset is for {radius} m"
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
                samplers[spec.name] = EpisodeSampler(spec)
            eps = samplers[spec.name].episodes(n, seed=stable_split_seed(split.name), cross_room=cross)
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


def stable_split_seed(name: str) -> int:
    from biovln_ms.episodes.generator import stable_seed

    return stable_seed("split", name)


class EpisodeDataset:
    """A validated dataset folder: splits, scene specs and episodes."""

    def __init__(
        self, root: str | Path, agent_radius: float | None = ROBOT_RADIUS, verify: bool = True
    ) -> None:
        self.root = Path(root)
        mpath = self.root / "manifest.json"
        if not mpath.exists():
            partial = list(self.root.parent.glob(f".{self.root.name}.partial-*"))
            hint = " (an interrupted build left a partial folder: run the build again)" if partial else ""
            raise DatasetError(
                f"no manifest.json{hint}",
                source=str(self.root),
                fix="build it: biovln-ms dataset build --out DIR",
            )
        try:
            self.manifest = json.loads(mpath.read_text())
        except json.JSONDecodeError as e:
            raise DatasetError(f"manifest is not valid JSON ({e.msg})", source=str(mpath)) from None
        m = self.manifest
        if not m.get("complete"):
            raise DatasetError("the dataset is incomplete", source=str(mpath), fix="rebuild it")
        if m.get("format_version") != DATASET_FORMAT_VERSION:
            raise DatasetError(
                f"format_version {m.get('format_version')} is not {DATASET_FORMAT_VERSION}",
                source=str(mpath),
                field="format_version",
                fix="rebuild it with this version of biovln-ms",
            )
        if agent_radius is not None and abs(m.get("agent_radius", -1) - agent_radius) > 1e-9:
            raise DatasetError(
                f"built for a {m.get('agent_radius')} m agent, not the {agent_radius} m agent in use: its "
                f"geodesic distances (hence SPL) would be wrong",
                source=str(mpath),
                field="agent_radius",
                fix="rebuild the dataset for this radius, or use the robot it was built for",
            )
        versions = {
            "scene_generator_version": SCENE_GENERATOR_VERSION,
            "episode_generator_version": EPISODE_GENERATOR_VERSION,
        }
        for key, want in versions.items():
            if m.get(key) != want:
                raise DatasetError(
                    f"made by {key.replace('_', ' ')} {m.get(key)}, this build is {want}: its scenes or "
                    f"episodes differ from what this version generates",
                    source=str(mpath),
                    field=key,
                    fix="rebuild it: biovln-ms dataset build --out DIR",
                )
        if m.get("catalog_sha256") != load_catalog().sha256:
            raise DatasetError(
                "built from another instrument catalog (goals and radii may differ)",
                source=str(mpath),
                field="catalog_sha256",
                fix="rebuild the dataset with the installed catalog",
            )
        if verify:
            for name, info in m["scenes"].items():
                self._check(info["file"], info["sha256"])
            for split in m["splits"].values():
                for info in split["files"].values():
                    self._check(info["file"], info["sha256"])
        self._specs: dict[str, SceneSpec] = {}

    def _check(self, rel: str, digest: str) -> None:
        p = self.root / rel
        if not p.exists():
            raise DatasetError(
                "file listed in the manifest is missing", source=str(p), fix="rebuild the dataset"
            )
        if sha256(p.read_bytes()) != digest:
            raise DatasetError(
                "file does not match its hash in the manifest (corrupt or edited)",
                source=str(p),
                fix="rebuild the dataset",
            )

    @property
    def agent_radius(self) -> float:
        return self.manifest["agent_radius"]

    def split_names(self) -> list[str]:
        return list(self.manifest["splits"])

    def split_info(self, split: str) -> dict:
        if split not in self.manifest["splits"]:
            raise DatasetError(
                f"unknown split '{split}'", field="split", fix=f"use one of: {', '.join(self.split_names())}"
            )
        info = self.manifest["splits"][split]
        if info.get("missing") and not info["files"]:
            raise DatasetError(f"split '{split}' is not built: {info['missing']}", field="split")
        return info

    def spec(self, scene: str) -> SceneSpec:
        if scene not in self._specs:
            if scene not in self.manifest["scenes"]:
                raise DatasetError(f"unknown scene '{scene}'", field="scene_id")
            self._specs[scene] = load_spec(self.root / self.manifest["scenes"][scene]["file"])
        return self._specs[scene]

    def episodes(self, split: str) -> Iterator[dict]:
        info = self.split_info(split)
        for scene in info["scenes"]:
            with gzip.open(self.root / info["files"][scene]["file"], "rt") as f:
                yield from json.load(f)["episodes"]

    def stats(self, split: str) -> dict:
        eps = list(self.episodes(split))
        diff = Counter(e["info"]["difficulty"] for e in eps)
        n = max(len(eps), 1)
        return {
            "scenes": len(self.split_info(split)["scenes"]),
            "episodes": len(eps),
            "categories": sorted({e["object_category"] for e in eps}),
            "difficulty": {k: round(100 * diff.get(k, 0) / n, 1) for k in ("easy", "medium", "hard")},
            "start_fallback": sum(e["info"]["start_clearance_fallback"] for e in eps),
        }
