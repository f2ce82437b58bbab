"""habitat-lab bridge: a dataset split as an ObjectNav-v1 dataset (``biovln-ms dataset export habitat``).

Layout under ``out``::

    objectnav/<split>/<split>.json.gz          episodes, goals_by_category and the category maps
    scenes/<scene>.glb                         the scenes (``export_scene_glb``, glTF's Y-up frame)
    scenes/biovln.scene_dataset_config.json    habitat-sim scene dataset: every GLB beside it is a stage

Frames: ours is Z-up (an agent at yaw 0 faces +x); habitat's is Y-up (x right, y up, an agent faces its
-z). A point (x, y, z) becomes (x, z, -y), as in the GLB; a rotation is carried into that frame and turned
so habitat's forward points where ours did, which takes a yaw t about +z to t - 90 degrees about +y.
Quaternions go from our [w, x, y, z] to habitat's [x, y, z, w], with w >= 0.

Episodes keep our ids, start, info (plus ``target_object_id``) and category; ``scene_id`` is
``<scene>.glb`` (under ``scenes_dir``) and ``scene_dataset_config`` the config's path as ``out`` was
given (habitat-lab resolves it from its working folder). A goal is an instrument: ``position`` and
``radius`` are our navigable operational-face goal and success radius, ``view_points`` ours (with
``iou`` null). ``goals_by_category["<scene>.glb_<category>"]`` holds every instrument of that category
that the split's episodes target: habitat-lab counts reaching any of them, where we count only the
episode's target (the same whenever a scene has one instrument of the category). A protocol split
(K ordered goals per episode, ``BioVLN-Protocol-v0``) has no ObjectNav form and is refused in one line.
"""

from __future__ import annotations

import json
import math
import re
from pathlib import Path
from typing import Iterable, Sequence

from biovln_ms.catalog import load_catalog
from biovln_ms.errors import BioVLNError
from biovln_ms.episodes.dataset import EpisodeDataset
from biovln_ms.episodes.writer import gz_json
from biovln_ms.io_utils import atomic_write_bytes, atomic_write_text
from biovln_ms.scene.export_glb import export_scene_glb

SCENE_DATASET_CONFIG = "biovln.scene_dataset_config.json"
_H = math.sqrt(0.5)
_TO_Y_UP = (_H, -_H, 0.0, 0.0)  # [w, x, y, z]: -90 degrees about x, (x, y, z) -> (x, z, -y)
_FROM_Y_UP = (_H, _H, 0.0, 0.0)
_FORWARD = (_H, 0.0, -_H, 0.0)  # -90 degrees about y: habitat's forward (-z) onto +x


def _qmul(a: Sequence[float], b: Sequence[float]) -> tuple[float, float, float, float]:
    """Hamilton product of [w, x, y, z] quaternions."""
    aw, ax, ay, az = a
    bw, bx, by, bz = b
    return (
        aw * bw - ax * bx - ay * by - az * bz,
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
    )


def to_habitat_position(p: Sequence[float]) -> list[float]:
    """Our Z-up point (x, y, z) as habitat's Y-up (x, z, -y)."""
    return [p[0] + 0.0, p[2] + 0.0, -p[1] + 0.0]  # + 0.0: no -0.0 in the files


def to_habitat_rotation(q: Sequence[float]) -> list[float]:
    """Our agent rotation ([w, x, y, z], forward +x) as habitat's ([x, y, z, w], forward -z), w >= 0."""
    w, x, y, z = _qmul(_qmul(_qmul(_TO_Y_UP, q), _FROM_Y_UP), _FORWARD)
    sign = -1.0 if w < 0 else 1.0
    return [round(sign * v, 6) + 0.0 for v in (x, y, z, w)]


def _agent_state(state: dict) -> dict:
    return {
        "position": to_habitat_position(state["position"]),
        "rotation": to_habitat_rotation(state["rotation"]),
    }


def _goal(g: dict) -> dict:
    return {
        "object_id": g["object_id"],
        "object_name": g["object_id"],
        "object_category": g["object_category"],
        "position": to_habitat_position(g["position"]),
        "radius": g["radius"],
        "view_points": [
            {"agent_state": _agent_state(v["agent_state"]), "iou": None} for v in g["view_points"]
        ],
    }


def habitat_dataset(episodes: Iterable[dict], scene_dataset_config: str) -> dict:
    """The ObjectNav-v1 JSON object of ``episodes`` (ours, as ``EpisodeDataset.episodes`` gives them)."""
    cat = load_catalog()
    out_eps, goals = [], {}
    for ep in episodes:
        scene_file = f"{ep['scene_id']}.glb"
        for g in ep["goals"]:
            goals.setdefault(f"{scene_file}_{g['object_category']}", {}).setdefault(g["object_id"], _goal(g))
        out_eps.append(
            {
                "episode_id": ep["episode_id"],
                "scene_id": scene_file,
                "scene_dataset_config": scene_dataset_config,
                "start_position": to_habitat_position(ep["start_position"]),
                "start_rotation": to_habitat_rotation(ep["start_rotation"]),
                "object_category": ep["object_category"],
                "info": {**ep["info"], "target_object_id": ep["object_id"]},
                "goals": [],
            }
        )
    return {
        "episodes": out_eps,
        "goals_by_category": {k: [v[i] for i in sorted(v)] for k, v in sorted(goals.items())},
        "category_to_task_category_id": {c: i for i, c in enumerate(cat.goal_categories())},
        "category_to_scene_annotation_category_id": {c: cat.names().index(c) for c in cat.goal_categories()},
    }


def scene_dataset_config() -> dict:
    """habitat-sim's scene dataset config: each GLB in its folder is a Y-up stage in metres."""
    return {
        "stages": {
            "default_attributes": {
                "up": [0, 1, 0],
                "front": [0, 0, -1],
                "origin": [0, 0, 0],
                "units_to_meters": 1.0,
            },
            "paths": {".glb": ["*.glb"]},
        }
    }


def export_habitat(ds: EpisodeDataset, split: str, out: str | Path) -> list[Path]:
    """Write ``split`` of ``ds`` under ``out`` (module docstring), each file atomically; returns them, the
    scene GLBs first."""
    out = Path(out)
    scenes = ds.split_info(split)["scenes"]
    if not re.fullmatch(r"[A-Za-z0-9_][A-Za-z0-9_.-]*", split):
        raise BioVLNError(f"split name {split!r} cannot name a folder", field="split", fix="rename the split")
    episodes = list(ds.episodes(split))
    if any("protocol" in ep for ep in episodes):
        raise BioVLNError(
            f"split '{split}' holds protocol (multi-goal) episodes, which ObjectNav-v1 cannot express",
            field="split",
            fix="export a single-goal split; protocol splits run in BioVLN-Protocol-v0",
        )
    config = out / "scenes" / SCENE_DATASET_CONFIG
    data = habitat_dataset(episodes, config.as_posix())
    files = [export_scene_glb(ds.spec(s), out / "scenes" / f"{s}.glb") for s in scenes]
    files.append(atomic_write_text(config, json.dumps(scene_dataset_config(), indent=1) + "\n"))
    files.append(atomic_write_bytes(out / "objectnav" / split / f"{split}.json.gz", gz_json(data)))
    return files
