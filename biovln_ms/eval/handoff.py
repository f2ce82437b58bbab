"""Hand-off from navigation to manipulation: where a successful episode ended, as a
manipulation task needs it to start there.

``biovln-ms eval ... --export-handoff DIR`` writes one JSON file per successful episode the command runs,
``DIR/<run>/<split>/<scene_id>/<episode_id>.json``, atomically (a temporary file renamed into place). Its
keys (``HANDOFF_SCHEMA``; the docs' "Hand-off" section shows an example):

* ``schema``, and the run: ``method``, ``env_id``, ``split``, ``dataset`` (the folder, or null for the
  robot's default dataset), ``noise``, ``robot``;
* the episode: ``scene_id``, ``episode_id``, ``object_id``, ``object_category``, ``success`` (always true),
  ``strict_success``, and for Fetch ``reachable`` / ``reach_success`` (null for the cylinder, which has no
  arm);
* ``base_pose_world``: x, y (m), yaw (rad) where the base stopped;
* ``instrument``: the target's ``center`` (its bounding box's, world), ``yaw``, ``size``, ``face_model``
  (the operational face's unit normal in its own frame), ``interaction_point_model`` /
  ``interaction_point_world`` (the catalog's, null when its category has none);
* ``base_pose_instrument``: the base in the instrument's frame (origin at its bounding box's centre on
  the floor, axes its model axes): x, y, yaw, and ``face_distance`` (from the face plane along its normal)
  and ``lateral_offset`` (along the face, from its centre line);
* ``joints``: ``names`` (the articulation's active joints, ManiSkill's order: the planar base joints
  first) and ``qpos`` at the STOP; ``reach_qpos``: Fetch's configuration reaching the interaction point
  (the reach check's IK solution, same joints), or null;
* ``scene_spec``: the whole scene spec (``SceneSpec``'s JSON), so the scene can be rebuilt without the
  dataset.

:func:`restore_handoff` puts a fresh env of the same split and robot back into that state.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from biovln_ms.catalog import load_catalog
from biovln_ms.errors import BioVLNError
from biovln_ms.geometry.zones import rot2, wrap_angle
from biovln_ms.io_utils import atomic_write_text, inside
from biovln_ms.scene.spec import ObjectSpec, SceneSpec

HANDOFF_SCHEMA = "biovln-ms/handoff/1"
ARM_STATES = ("navigation", "reach")  # restore the joints as they were at the STOP, or reaching


class HandoffError(BioVLNError):
    """A hand-off file that cannot be read or restored."""


def instrument_frame(pose: np.ndarray, obj: ObjectSpec) -> dict[str, float]:
    """Planar ``pose`` (x, y, yaw) in ``obj``'s frame (origin at its bounding box's centre on the floor,
    axes its model axes), with its distance from the operational face's plane and its offset along it."""
    local = rot2(obj.yaw).T @ (np.asarray(pose[:2], float) - np.asarray(obj.position[:2], float))
    out = {"x": float(local[0]), "y": float(local[1]), "yaw": wrap_angle(float(pose[2]) - obj.yaw)}
    placed = obj.placed()
    if placed.model_face is not None:
        f = np.asarray(placed.model_face)
        out["face_distance"] = float(local @ f - placed.d_half)
        out["lateral_offset"] = float(local @ np.array([-f[1], f[0]]))
    return out


def handoff_payload(env, info: dict, run: dict) -> dict:
    """The hand-off of sub-env 0's episode, just ended in ``env`` with ``info``; ``run``: the eval worker's
    config (method, env_id, split, dataset, noise, robot)."""
    u = env.unwrapped
    ep, spec = u.current_episode, u.scene_spec
    obj = spec.get(ep["object_id"])
    pose = np.asarray(info["agent_pose"][0].cpu().numpy(), float)
    asset = load_catalog().get(obj.category)
    point_model = list(asset.interaction.point) if asset.interaction is not None else None
    point_world = None
    if point_model is not None:
        xy = np.asarray(obj.position[:2]) + rot2(obj.yaw) @ np.asarray(point_model[:2])
        point_world = [float(xy[0]), float(xy[1]), float(obj.position[2] + point_model[2])]
    reach = u.reach_configuration(0)
    fetch = "reachable" in info
    return {
        "schema": HANDOFF_SCHEMA,
        **{k: run.get(k) for k in ("method", "env_id", "split", "dataset", "noise", "robot")},
        "scene_id": ep["scene_id"],
        "episode_id": ep["episode_id"],
        "object_id": obj.id,
        "object_category": obj.category,
        "success": bool(info["success"]),
        "strict_success": bool(info["strict_success"]),
        "reachable": bool(info["reachable"]) if fetch else None,
        "reach_success": bool(info["reach_success"]) if fetch else None,
        "base_pose_world": {"x": float(pose[0]), "y": float(pose[1]), "yaw": float(pose[2])},
        "base_pose_instrument": instrument_frame(pose, obj),
        "instrument": {
            "center": list(obj.position),
            "yaw": obj.yaw,
            "size": list(obj.size),
            "face_model": list(obj.placed().model_face) if obj.face is not None else None,
            "interaction_point_model": point_model,
            "interaction_point_world": point_world,
        },
        "joints": {
            "names": list(u.agent.robot.active_joints_map),
            "qpos": [float(v) for v in u.agent.robot.get_qpos()[0].cpu().numpy()],
        },
        "reach_qpos": None if reach is None else [float(v) for v in reach],
        "scene_spec": json.loads(spec.to_json()),
    }


def handoff_path(root: str | Path, run: str, split: str, scene_id: str, episode_id) -> Path:
    """Where ``--export-handoff root`` writes an episode's hand-off: always inside ``root``. An id that is
    not one plain name (``..``, ``/``, empty, absolute) is refused with a ``HandoffError``, so a crafted
    dataset cannot make the export write elsewhere."""
    return inside(
        root,
        str(run),
        str(split),
        str(scene_id),
        f"{episode_id}.json",
        what="hand-off file",
        error=HandoffError,
        field="scene_id/episode_id",
        fix="ids are letters, digits, '_', '-' and '.': rebuild the dataset",
    )


def write_handoff(root: str | Path, run: str, payload: dict) -> Path:
    """Write ``payload`` atomically under ``root`` (see :func:`handoff_path`); returns the file."""
    path = handoff_path(root, run, payload["split"], payload["scene_id"], payload["episode_id"])
    path.parent.mkdir(parents=True, exist_ok=True)
    atomic_write_text(path, json.dumps(payload, indent=1, sort_keys=True) + "\n")
    return path


def load_handoff(path: str | Path) -> dict:
    """A hand-off file's content; a one-line HandoffError for a missing, unreadable or foreign file."""
    path = Path(path)
    try:
        data = json.loads(path.read_text())
    except OSError as e:
        raise HandoffError(f"cannot read it ({e.strerror})", source=str(path)) from None
    except json.JSONDecodeError as e:
        raise HandoffError(f"not valid JSON at line {e.lineno}: {e.msg}", source=str(path)) from None
    if not isinstance(data, dict) or data.get("schema") != HANDOFF_SCHEMA:
        raise HandoffError(
            f"not a hand-off file of schema {HANDOFF_SCHEMA}",
            source=str(path),
            field="schema",
            fix="export it again with `biovln-ms eval ... --export-handoff DIR`",
        )
    return data


def restore_handoff(env, path: str | Path, arm: str = "navigation") -> dict:
    """Reset ``env`` (made on the hand-off's split and robot) to the hand-off's episode and put the robot
    where it stopped: the base at ``base_pose_world`` at rest, the joints at ``joints.qpos`` (``arm=
    "navigation"``) or at ``reach_qpos`` (``arm="reach"``, Fetch reaching the interaction point). The
    navigation controller's drive targets stay its own (the arm's tuck pose): a manipulation controller
    takes over from this state. The env's info is the episode start's until the next step. Returns the
    hand-off."""
    h = load_handoff(path)
    u = env.unwrapped
    if arm not in ARM_STATES:
        raise HandoffError(
            f"unknown arm state '{arm}'", field="arm", fix=f"use one of: {', '.join(ARM_STATES)}"
        )
    if u.robot_id != h["robot"]:
        raise HandoffError(
            f"the hand-off was made on robot '{h['robot']}', the env runs '{u.robot_id}'",
            source=str(path),
            field="robot",
            fix=f"make the env with robot_uids='{h['robot']}'",
        )
    env.reset(options={"scene_id": h["scene_id"], "episode_id": h["episode_id"]})
    if u.scene_spec.to_json() != SceneSpec.model_validate(h["scene_spec"]).to_json():
        raise HandoffError(
            f"the env's scene '{h['scene_id']}' is not the hand-off's",
            source=str(path),
            field="scene_spec",
            fix=f"make the env on its dataset ({h['dataset'] or 'the default'}) and split ({h['split']})",
        )
    names = list(u.agent.robot.active_joints_map)
    if names != h["joints"]["names"]:
        raise HandoffError(
            "the robot's joints are not the hand-off's", source=str(path), field="joints.names"
        )
    q = h["reach_qpos"] if arm == "reach" else h["joints"]["qpos"]
    if q is None:
        raise HandoffError(
            "the hand-off has no reaching configuration",
            source=str(path),
            field="reach_qpos",
            fix="use arm='navigation'",
        )
    import torch

    qpos = torch.tensor([q], dtype=torch.float32, device=u.device)
    u.agent.robot.set_qpos(qpos)
    b = h["base_pose_world"]
    u.agent.controller.put_back([0], np.array([[b["x"], b["y"], b["yaw"]]]))
    return h
