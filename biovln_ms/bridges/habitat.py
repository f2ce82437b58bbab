"""habitat-lab bridge: a dataset split as an ObjectNav-v1 dataset (``biovln-ms dataset export habitat``).

Targets habitat-sim 0.2.2 (scene dataset, scene instance and HM3D-format semantic descriptor) and
habitat-lab's ObjectNav-v1 dataset classes (0.2.2 to 0.3.3 share its fields). Layout under ``out``::

    objectnav/<split>/<split>.json.gz          episodes, goals_by_category and the category maps
    scenes/<scene>.scene_instance.json         the scene an episode names: stage + overhead object
    scenes/<scene>.glb, .overhead.glb, .semantic.glb, .semantic.txt, *_config.json
                                               ``bridges.habitat_scene``: navmesh-safe stage,
                                               render-only overhead, instance semantics
    scenes/biovln.scene_dataset_config.json    habitat-sim scene dataset over every scene in the folder

Frames: ours is Z-up (an agent at yaw 0 faces +x); habitat's is Y-up (x right, y up, an agent faces its
-z). A point (x, y, z) becomes (x, z, -y), as in the GLB; a rotation is carried into that frame and turned
so habitat's forward points where ours did, which takes a yaw t about +z to t - 90 degrees about +y.
Quaternions go from our [w, x, y, z] to habitat's [x, y, z, w], with w >= 0.

Episodes keep our ids, start, info (plus ``target_object_id``, our id of the target) and category;
``scene_id`` is ``<scene>.scene_instance.json`` (under ``scenes_dir``) and ``scene_dataset_config`` the
config's path as ``out`` was given. A goal is an object as habitat-lab means it: ``object_id`` its
instance id in the semantic scene, ``object_name`` our id, ``position`` its bounding-box centre;
``view_points`` are our standing poses (the first is the Eq. 1 goal g = c + f(d + delta) snapped to
the floor), ``radius`` our success radius around that first view point, ``iou`` null.
``goals_by_category["<scene>.scene_instance.json_<category>"]`` holds every object of that category
that the split's episodes target: habitat-lab counts reaching any of them, where we count only the
episode's target. A protocol split (K ordered goals per episode) has no ObjectNav form and is refused.
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
from biovln_ms.bridges.habitat_scene import SceneSemantics, export_habitat_scene
from biovln_ms.scene.export_glb import _chunks

SCENE_DATASET_CONFIG = "biovln.scene_dataset_config.json"
SCENE_INSTANCE_SUFFIX = ".scene_instance.json"
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


def _goal(g: dict, semantics: SceneSemantics) -> dict:
    oid = g["object_id"]
    return {
        "object_id": semantics.instance_ids[oid],
        "object_name": oid,
        "object_category": g["object_category"],
        "position": semantics.centres[oid],
        "radius": g["radius"],
        "view_points": [
            {"agent_state": _agent_state(v["agent_state"]), "iou": None} for v in g["view_points"]
        ],
    }


def annotation_categories(stage_glb: bytes) -> list[str]:
    """The categories of a written scene GLB's ``asset.extras.semantic_colors``, in the file's order."""
    gltf, _ = _chunks(stage_glb)
    return list(gltf["asset"]["extras"]["semantic_colors"])


def habitat_dataset(
    episodes: Iterable[dict],
    scene_dataset_config: str,
    semantics: dict[str, SceneSemantics],
    annotation_order: Sequence[str],
) -> dict:
    """The ObjectNav-v1 JSON object of ``episodes`` (ours, as ``EpisodeDataset.episodes`` gives them),
    with each scene's instance ids and object centres (``export_habitat_scene``) and the category order
    of the written GLBs' ``semantic_colors``."""
    cat = load_catalog()
    out_eps, goals = [], {}
    for ep in episodes:
        scene_file = f"{ep['scene_id']}{SCENE_INSTANCE_SUFFIX}"
        for g in ep["goals"]:
            goals.setdefault(f"{scene_file}_{g['object_category']}", {}).setdefault(
                g["object_id"], _goal(g, semantics[ep["scene_id"]])
            )
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
        "category_to_scene_annotation_category_id": {
            c: list(annotation_order).index(c) for c in cat.goal_categories()
        },
    }


def scene_dataset_config(scenes: Iterable[str]) -> dict:
    """habitat-sim's scene dataset config over the scenes (all of them in the folder): stages, the
    overhead objects and scene instances by file pattern, semantic descriptors by scene name."""
    return {
        "stages": {
            "default_attributes": {
                "up": [0, 1, 0],
                "front": [0, 0, -1],
                "origin": [0, 0, 0],
                "units_to_meters": 1.0,
            },
            "paths": {".json": ["*.stage_config.json"]},
        },
        "objects": {"paths": {".json": ["*.object_config.json"]}},
        "scene_instances": {"paths": {".json": [f"*{SCENE_INSTANCE_SUFFIX}"]}},
        "semantic_scene_descriptor_instances": {s: f"{s}.semantic.txt" for s in sorted(scenes)},
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
    scenes_dir = out / "scenes"
    files, semantics = [], {}
    for s in scenes:
        written, semantics[s] = export_habitat_scene(ds.spec(s), scenes_dir)
        files += written
    order = annotation_categories((scenes_dir / f"{scenes[0]}.glb").read_bytes())
    config = scenes_dir / SCENE_DATASET_CONFIG
    in_folder = [p.name.removesuffix(".semantic.txt") for p in scenes_dir.glob("*.semantic.txt")]
    files.append(atomic_write_text(config, json.dumps(scene_dataset_config(in_folder), indent=1) + "\n"))
    data = habitat_dataset(episodes, config.as_posix(), semantics, order)
    files.append(atomic_write_bytes(out / "objectnav" / split / f"{split}.json.gz", gz_json(data)))
    return files
