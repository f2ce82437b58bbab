"""The BioVLN-MS mobile base, registered with ManiSkill as ``biovln_base``.

Built from ``agents/assets/biovln_base.urdf`` (shipped, nothing downloaded): a 0.20 m-radius,
0.95 m-tall cylinder on three planar joints (x, y, yaw) driven by a stiff PD position drive, so a
commanded pose is reached exactly when free and the body is stopped by walls and instruments by
SAPIEN's contact solver. The head camera sits on ``camera_link`` at 0.88 m (Habitat's ObjectNav
sensor height), looking along the base's heading.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import sapien
from mani_skill.agents.base_agent import BaseAgent, Keyframe
from mani_skill.agents.controllers import PDJointPosControllerConfig
from mani_skill.agents.registration import register_agent

from biovln_ms.constants import ROBOT_RADIUS

URDF_PATH = Path(__file__).resolve().parent / "assets" / "biovln_base.urdf"
BASE_JOINTS = ("root_x_joint", "root_y_joint", "root_yaw_joint")
BODY_HEIGHT = 0.95
CAMERA_HEIGHT = 0.88
DRIVE_STIFFNESS = 3e6
DRIVE_DAMPING = 1e4
DRIVE_FORCE_LIMIT = 1e5


@register_agent()
class BioVLNBase(BaseAgent):
    uid = "biovln_base"
    urdf_path = str(URDF_PATH)
    fix_root_link = True
    disable_self_collisions = True
    radius = ROBOT_RADIUS
    keyframes = dict(rest=Keyframe(pose=sapien.Pose(), qpos=np.zeros(3)))
    # Frictionless body: contact with a wall stops the base (and lets it slide along the wall, as
    # Habitat's agents do) without friction torques twisting its heading.
    urdf_config = dict(_materials=dict(body=dict(static_friction=0.0, dynamic_friction=0.0, restitution=0.0)),
                       link=dict(base_link=dict(material="body")))

    @property
    def _controller_configs(self):
        # Absolute joint targets, not normalised: the env turns its discrete or continuous actions
        # into exact planar targets (see biovln_ms.tasks.nav_env).
        return dict(pd_base_pos=PDJointPosControllerConfig(
            list(BASE_JOINTS), lower=None, upper=None, stiffness=DRIVE_STIFFNESS, damping=DRIVE_DAMPING,
            force_limit=DRIVE_FORCE_LIMIT, normalize_action=False, use_delta=False))

    def _after_init(self):
        self.base_link = self.robot.links_map["base_link"]
        self.camera_link = self.robot.links_map["camera_link"]

    def planar_pose(self) -> np.ndarray:
        """(num_envs, 3): x, y, yaw from the joint positions."""
        q = self.robot.get_qpos()
        return q.cpu().numpy() if hasattr(q, "cpu") else np.asarray(q)
