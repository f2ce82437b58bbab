"""Fetch for navigation, registered with ManiSkill as ``fetch_nav`` (the task's ``robot_uids="fetch"``).

ManiSkill's Fetch (its URDF and meshes ship inside the ``mani_skill`` package; nothing is downloaded) with
the navigation controller of :mod:`biovln_ms.agents.robots.locomotion` instead of ManiSkill's velocity
base: the same ``discrete`` (``Discrete(4)``) and ``continuous`` (``Box(-1, 1, (3,))``) modes drive the
planar joints ``root_x_axis_joint`` / ``root_y_axis_joint`` / ``root_z_rotation_joint`` to the commanded pose
through a stiff PD position drive, and every other joint is held at the tuck pose (:data:`TUCK`) by the
same controller. The task's head camera is mounted on ``head_camera_link``; ManiSkill's own 128 x 128
``fetch_head`` / ``fetch_hand`` cameras are not added.

Contacts are frictionless, as the cylinder's: the base link's collision mesh stops at walls and instruments
and slides along them; the floor's contact is vertical, so it never resists a planar move. Self-collisions
are off (the held joints never move). The base is not round: the footprint disc of
``biovln_ms.robot_specs.ROBOTS["fetch"]`` (0.29 m) encloses it (0.288 m ahead and behind), its sides are
0.264 m from the yaw axis, so side-on it may stand a little nearer an obstacle than the disc, and turning
while in contact may push it a few centimetres.
"""

from __future__ import annotations

import numpy as np
import sapien
from mani_skill.agents.base_agent import Keyframe
from mani_skill.agents.registration import register_agent
from mani_skill.agents.robots.fetch.fetch import Fetch

from biovln_ms.agents.robots.biovln_base import NavAgent
from biovln_ms.agents.robots.locomotion import CONTROL_MODES, LocomotionControllerConfig

BASE_JOINTS = ("root_x_axis_joint", "root_y_axis_joint", "root_z_rotation_joint")
PLANAR_LIMIT = 1000.0  # m, the planar joints' range (the cylinder's)
#: the held joints' targets (rad, m), in the articulation's joint order: torso down, head level and
#: straight ahead, the arm folded over the base in Fetch's standard tuck (inside the base's footprint),
#: gripper closed
TUCK = {
    "torso_lift_joint": 0.0,
    "head_pan_joint": 0.0,
    "shoulder_pan_joint": 1.32,
    "head_tilt_joint": 0.0,
    "shoulder_lift_joint": 1.40,
    "upperarm_roll_joint": -0.20,
    "elbow_flex_joint": 1.72,
    "forearm_roll_joint": 0.0,
    "wrist_flex_joint": 1.66,
    "wrist_roll_joint": 0.0,
    "r_gripper_finger_joint": 0.0,
    "l_gripper_finger_joint": 0.0,
}
#: the planar drive: the cylinder's stiffness (3e6 N/m for 22 kg) scaled to Fetch's 121 kg, so a 0.25 m
#: step settles within the five physics substeps of an action; critically damped, so a base released at
#: an obstacle's corner overshoots little; the cylinder's force limit (a larger one pressed the base into
#: walls hard enough to make the contact solver throw the arm about)
BASE_STIFFNESS = 1.7e7
BASE_DAMPING = 9e4
BASE_FORCE_LIMIT = 1e5
#: the held joints: stiff enough that a step's accelerations swing no joint more than 0.01 rad
HOLD_STIFFNESS = 1e7
HOLD_DAMPING = 1e5
HOLD_FORCE_LIMIT = 1e5


@register_agent()
class FetchNav(NavAgent, Fetch):
    uid = "fetch_nav"
    robot_id = "fetch"
    keyframes = dict(rest=Keyframe(pose=sapien.Pose(), qpos=np.array([0.0, 0.0, 0.0, *TUCK.values()])))
    disable_self_collisions = True
    urdf_config = dict(
        _materials=dict(body=dict(static_friction=0.0, dynamic_friction=0.0, restitution=0.0)),
        link={name: dict(material="body") for name in ("base_link", "l_wheel_link", "r_wheel_link")},
    )

    @property
    def _sensor_configs(self):
        return []  # the task mounts its head camera on head_camera_link

    @property
    def _controller_configs(self):
        n = len(TUCK)
        return {
            mode: LocomotionControllerConfig(
                list(BASE_JOINTS) + list(TUCK),
                lower=None,
                upper=None,
                stiffness=[BASE_STIFFNESS] * 3 + [HOLD_STIFFNESS] * n,
                damping=[BASE_DAMPING] * 3 + [HOLD_DAMPING] * n,
                force_limit=[BASE_FORCE_LIMIT] * 3 + [HOLD_FORCE_LIMIT] * n,
                normalize_action=False,
                mode=mode,
                hold=tuple(TUCK.values()),
            )
            for mode in CONTROL_MODES
        }

    def _after_init(self):
        super()._after_init()
        self.camera_link = self.head_camera_link
        for name in BASE_JOINTS[:2]:  # the URDF's +-20 m would stop the base inside a larger building
            for joint in self.robot.joints_map[name]._objs:
                joint.set_limits([[-PLANAR_LIMIT, PLANAR_LIMIT]])
