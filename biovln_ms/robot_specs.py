"""The robots a navigation task can run, as the pure model knows them: one row per robot (``ROBOTS``).

The footprint radius is the one source of truth for a robot's navigation geometry: free space, geodesics,
episode starts and goals (``biovln_ms.geometry``, ``biovln_ms.episodes``), the scenes' layout rules and the
dataset a robot may load (its manifest records the robot it was built for). The simulator's agents
(``biovln_ms.agents.robots``) are tested against these rows: the cylinder's collision radius and camera
mount, Fetch's collision meshes in the tuck pose and its head camera link.
"""

from __future__ import annotations

from dataclasses import dataclass

from biovln_ms.errors import BioVLNError


class RobotError(BioVLNError):
    """An unknown robot id."""


@dataclass(frozen=True)
class RobotSpec:
    """What the navigation model needs of a robot (metres)."""

    uid: str  # the id ``gym.make(..., robot_uids=...)`` and ``dataset build --robot`` take
    footprint_radius: float  # the disc about the turning centre enclosing every collision shape
    camera_height: float  # the head camera's optical centre above the floor
    description: str


#: the default robot: the benchmark's datasets and every tool that names no robot use it
DEFAULT_ROBOT = "biovln_base"

ROBOTS: dict[str, RobotSpec] = {
    # a 0.20 m cylinder, camera at Habitat's ObjectNav sensor height (agents/robots/assets/biovln_base.urdf)
    "biovln_base": RobotSpec("biovln_base", 0.20, 0.88, "the 0.20 m-radius cylinder base"),
    # ManiSkill's Fetch URDF: the base collision mesh reaches 0.288 m from the yaw axis (the tucked arm,
    # torso and head stay inside it), rounded up to the centimetre; the head camera link stands at
    # 0.37743 + 0.603 + 0.058 + 0.0225 = 1.061 m with the torso down and the head level
    "fetch": RobotSpec("fetch", 0.29, 1.061, "Fetch (ManiSkill's URDF), arm tucked, torso down"),
}


def robot_spec(uid: str, field: str = "robot_uids") -> RobotSpec:
    """Robot ``uid``'s row, or a one-line RobotError naming ``field`` and listing the supported robots."""
    if not isinstance(uid, str) or uid not in ROBOTS:
        raise RobotError(f"unknown robot {uid!r}", field=field, fix=f"use one of: {', '.join(ROBOTS)}")
    return ROBOTS[uid]
