"""The BioVLN-MS mobile base, registered with ManiSkill as ``biovln_base``, and its navigation controllers.

Built from ``agents/robots/assets/biovln_base.urdf`` (shipped, nothing downloaded): a 0.20 m-radius,
0.95 m-tall cylinder on three planar joints (x, y, yaw) driven by a stiff PD position drive, so a
commanded pose is reached exactly when free and the body is stopped by walls and instruments by
SAPIEN's contact solver. The head camera sits on ``camera_link`` at 0.88 m (Habitat's ObjectNav
sensor height), looking along the base's heading.

The navigation controllers (one per control mode, ``discrete`` and ``continuous``) are
:class:`~biovln_ms.agents.robots.locomotion.LocomotionController`, as every robot's; a robot with more joints
(Fetch, ``fetch_nav.py``) lists them after the planar ones and the same controller holds them at fixed
targets. :class:`NavAgent` is what the task asks of any robot's agent.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import sapien
import torch
from mani_skill.agents.base_agent import BaseAgent, Keyframe
from mani_skill.agents.registration import register_agent
from mani_skill.utils.structs.link import Link

from biovln_ms.agents.robots.locomotion import CONTROL_MODES, LocomotionController, LocomotionControllerConfig
from biovln_ms.robot_specs import robot_spec

__all__ = ["CONTROL_MODES", "BioVLNBase", "NavAgent", "urdf_body_radius"]

URDF_PATH = Path(__file__).resolve().parent / "assets" / "biovln_base.urdf"
BASE_JOINTS = ("root_x_joint", "root_y_joint", "root_yaw_joint")
BODY_HEIGHT = 0.95
DRIVE_STIFFNESS = 3e6
DRIVE_DAMPING = 1e4
DRIVE_FORCE_LIMIT = 1e5


class NavAgent:
    """What the navigation task asks of a robot, mixed into a ManiSkill agent with one
    :class:`LocomotionController` per control mode: its row in ``biovln_ms.robot_specs.ROBOTS``, its head
    camera link, planar poses in and out."""

    robot_id: str  # its ROBOTS row
    controller: LocomotionController
    camera_link: Link  # the head camera's mount (set in ``_after_init``)
    #: keyframe ``rest``: every active joint's position at rest (planar ones 0, held ones at their targets)
    keyframes: dict[str, Keyframe]

    def set_action(self, action):
        """The controller's, without ManiSkill's NumPy NaN scan of the action (a twentieth of a CPU step): the
        navigation controllers reject non-finite actions themselves, with a one-line ActionError."""
        self.controller.set_action(action)

    @property
    def radius(self) -> float:
        """The footprint radius (m) the navigation geometry uses."""
        return robot_spec(self.robot_id).footprint_radius

    def planar_pose(self) -> np.ndarray:
        """(num_envs, 3) float32 on the host: x, y, yaw from the joint positions."""
        return self.controller.host_qpos()

    def reset_planar(self, pose: torch.Tensor) -> None:
        """Stand at planar poses (rows of sub-envs being reset, x / y / yaw), at rest, every held joint at its
        target (ManiSkill's ``reset`` with the full joint positions)."""
        rest = self.keyframes["rest"].qpos
        qpos = torch.as_tensor(rest, dtype=pose.dtype, device=pose.device).repeat(len(pose), 1)
        qpos[:, self.controller.active_joint_indices[:3].to(pose.device)] = pose
        self.reset(qpos)


@register_agent()
class BioVLNBase(NavAgent, BaseAgent):
    uid = "biovln_base"
    robot_id = "biovln_base"
    urdf_path = str(URDF_PATH)
    fix_root_link = True
    disable_self_collisions = True
    keyframes = dict(rest=Keyframe(pose=sapien.Pose(), qpos=np.zeros(3)))
    # Frictionless body: contact with a wall stops the base (and lets it slide along the wall, as
    # Habitat's agents do) without friction torques twisting its heading.
    urdf_config = dict(
        _materials=dict(body=dict(static_friction=0.0, dynamic_friction=0.0, restitution=0.0)),
        link=dict(base_link=dict(material="body")),
    )

    @property
    def _controller_configs(self):
        return {
            mode: LocomotionControllerConfig(
                list(BASE_JOINTS),
                lower=None,
                upper=None,
                stiffness=DRIVE_STIFFNESS,
                damping=DRIVE_DAMPING,
                force_limit=DRIVE_FORCE_LIMIT,
                normalize_action=False,
                mode=mode,
            )
            for mode in CONTROL_MODES
        }

    def _after_init(self):
        self.base_link = self.robot.links_map["base_link"]
        self.camera_link = self.robot.links_map["camera_link"]

    @property
    def radius(self) -> float:
        """The body's radius (m), read from its collision cylinder in the URDF."""
        return urdf_body_radius()


def urdf_body_radius(path: Path = URDF_PATH) -> float:
    """The radius of the base link's collision cylinder."""
    import xml.etree.ElementTree as ET

    link = ET.parse(path).getroot().find("link[@name='base_link']")
    return float(link.find("collision/geometry/cylinder").get("radius"))
