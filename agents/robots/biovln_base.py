"""The BioVLN-MS mobile base, registered with ManiSkill as ``biovln_base``, and its navigation controllers.

Built from ``agents/robots/assets/biovln_base.urdf`` (shipped, nothing downloaded): a 0.20 m-radius,
0.95 m-tall cylinder on three planar joints (x, y, yaw) driven by a stiff PD position drive, so a
commanded pose is reached exactly when free and the body is stopped by walls and instruments by
SAPIEN's contact solver. The head camera sits on ``camera_link`` at 0.88 m (Habitat's ObjectNav
sensor height), looking along the base's heading.

Control modes (ManiSkill controllers, so ``env.control_mode`` and ``env.step`` are ManiSkill's):

* ``discrete``: ``Discrete(4)`` — 0 STOP, 1 FORWARD ``forward_step``, 2 TURN_LEFT, 3 TURN_RIGHT ``turn_deg``
  (paper §3.2);
* ``continuous``: ``Box(-1, 1, (3,))`` — [forward, turn, stop]: forward (a0 + 1) / 2 · step, turn a1 · turn
  angle, STOP when a2 > 0.

Either sets the planar joints' drive targets to the commanded pose and remembers the command
(:class:`NavCommand`) for the task's measures; a robot with more joints (Fetch, ``fetch_nav.py``) lists them
after the planar ones and the same controller holds them at fixed targets. :class:`NavAgent` is what the
task asks of any robot's agent. The task may move a forward target that lies beyond or deep
inside an obstacle (``limit``: no tunnelling at any step size, see ``biovln_ms.geometry.motion``) and hold
sub-envs whose episode has ended (``frozen``).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import sapien
import torch
from gymnasium import spaces
from mani_skill.agents.base_agent import BaseAgent, Keyframe
from mani_skill.agents.controllers import PDJointPosController, PDJointPosControllerConfig
from mani_skill.agents.registration import register_agent
from mani_skill.utils.structs.link import Link

from biovln_ms.errors import BioVLNError
from biovln_ms.robots import robot_spec

URDF_PATH = Path(__file__).resolve().parent / "assets" / "biovln_base.urdf"
BASE_JOINTS = ("root_x_joint", "root_y_joint", "root_yaw_joint")
BODY_HEIGHT = 0.95
DRIVE_STIFFNESS = 3e6
DRIVE_DAMPING = 1e4
DRIVE_FORCE_LIMIT = 1e5
ACTIONS = {0: "STOP", 1: "FORWARD", 2: "TURN_LEFT", 3: "TURN_RIGHT"}
#: a yaw drive target beyond this (rad) re-seats the yaw joint by a turn first: PhysX keeps the joint's
#: position within +-2 pi, so a target past it made the drive spin the long way round (+131 deg for a
#: 30 deg right turn)
YAW_RESEAT = 1.5 * math.pi
CONTROL_MODES = ("discrete", "continuous")


class ActionError(BioVLNError):
    """An action outside the control mode's action space."""


@dataclass
class NavCommand:
    """The last command, per sub-env: the pose it started from and what was asked (host arrays, like the
    task's measures that read it)."""

    start_pose: np.ndarray  # (N, 3) float64
    stop: np.ndarray  # (N,) bool
    forward: np.ndarray  # (N,) m along the heading, float64 (with actuation noise, the noisy one)
    turn: np.ndarray  # (N,) rad, float64 (idem)
    target: np.ndarray  # (N, 3) the pose the move aims at, before ``limit``


class NavBaseController(PDJointPosController):
    """Discrete or continuous navigation commands on the planar joints' stiff PD position drive; the
    config's held joints (after the three planar ones) keep fixed drive targets. The command arithmetic is
    NumPy on the host (a few numbers per sub-env; the drive targets go to the device)."""

    config: "NavBaseControllerConfig"

    def _initialize_action_space(self):
        if self.config.mode == "discrete":
            self.single_action_space = spaces.Discrete(len(ACTIONS))
        else:
            self.single_action_space = spaces.Box(-1.0, 1.0, (3,), np.float32)

    #: (pose (N, 3), target (N, 3), moving (N,) bool) -> the drive targets the swept body may take
    #: (set by the task)
    limit: Callable[[np.ndarray, np.ndarray, np.ndarray], np.ndarray] | None = None
    #: (N,) sub-envs whose episode has ended: their actions are ignored until reset (set by the task)
    frozen: np.ndarray | None = None
    #: (forward (N,), turn (N,), acting (N,) bool) -> the executed (along, across, turn): actuation noise
    #: (set by the task)
    perturb: Callable[[np.ndarray, np.ndarray, np.ndarray], tuple[np.ndarray, ...]] | None = None

    def set_motion(self, forward_step: float, turn_deg: float) -> None:
        """The distance of one FORWARD and the angle of one turn (the task's configuration)."""
        self.forward_step, self.turn = float(forward_step), math.radians(turn_deg)
        # per discrete action: stop, forward (m), turn (rad)
        self._table = np.array(
            [[1.0, 0.0, 0.0], [0.0, self.forward_step, 0.0], [0.0, 0.0, self.turn], [0.0, 0.0, -self.turn]]
        )

    def reset(self):
        super().reset()
        if not hasattr(self, "forward_step"):
            self.set_motion(self.config.forward_step, self.config.turn_deg)
        n = self.scene.num_envs
        pose = self.host_qpos().astype(np.float64)
        self.command = NavCommand(pose, np.zeros(n, dtype=bool), np.zeros(n), np.zeros(n), pose)
        if self.config.hold:
            self._hold = torch.tensor(self.config.hold, dtype=torch.float32, device=self.device)
            held = self._hold[None]  # one row: the sub-envs being reset take it on the GPU
            self.articulation.set_joint_drive_targets(held, self.joints[3:], self.active_joint_indices[3:])

    def _decode(self, action) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(stop, forward metres, turn radians) per sub-env, or an ActionError naming the action."""
        n = self.scene.num_envs
        a = action.cpu().numpy() if isinstance(action, torch.Tensor) else np.asarray(action)
        kind = a.dtype.kind
        finite = kind in "biu" or (kind == "f" and bool(np.isfinite(a).all()))
        if self.config.mode == "discrete":
            a = a.reshape(-1)
            if a.size != n or not finite or (kind == "f" and (a != np.round(a)).any()):
                raise ActionError(
                    f"action {a.tolist()} is not {n} integer(s)", field="action", fix=action_help()
                )
            k = a.astype(np.int64)
            if ((k < 0) | (k >= len(ACTIONS))).any():
                raise ActionError(
                    f"action {k.tolist()} is outside Discrete(4)", field="action", fix=action_help()
                )
            row = self._table[k]
            return row[:, 0] > 0, row[:, 1], row[:, 2]
        if a.size != 3 * n or not finite or np.abs(a).max() > 1.0 + 1e-6:
            raise ActionError(
                f"action {a.tolist()} is outside Box(-1, 1, (3,))",
                field="action",
                fix="continuous actions are [forward, turn, stop] in [-1, 1]: forward (a0+1)/2 * step, "
                "turn a1 * turn angle, stop when a2 > 0",
            )
        a = a.reshape(n, 3).astype(np.float64)
        return a[:, 2] > 0, (a[:, 0] + 1) / 2 * self.forward_step, a[:, 1] * self.turn

    def _initialize_joints(self):
        super()._initialize_joints()
        self._joint_columns = self.active_joint_indices[:3].cpu().numpy()  # the planar joints' qpos columns

    def host_qpos(self) -> np.ndarray:
        """(N, 3) float32 planar joint positions on the host: ManiSkill's ``qpos``, read straight from
        SAPIEN's articulation on the CPU backend (no tensor round trip: a tenth of a CPU step)."""
        if self.scene.gpu_sim_enabled:
            return self.qpos[:, :3].cpu().numpy()
        return self.articulation._objs[0].qpos[None, self._joint_columns]

    def _with_hold(self, planar: torch.Tensor) -> torch.Tensor:
        """(N, 3) planar values followed by the held joints' targets: a row of every controller joint."""
        if not self.config.hold:
            return planar
        return torch.cat([planar, self._hold.expand(len(planar), -1)], 1)

    def _set_host_targets(self, target: np.ndarray) -> torch.Tensor:
        """Planar drive targets from (N, 3) host values, as float32 like ManiSkill's; SAPIEN's joints are set
        directly on the CPU backend (what ManiSkill's per-joint setters do, without their tensor work)."""
        t32 = target.astype(np.float32)
        out = torch.from_numpy(t32).to(self.device)
        if self.scene.gpu_sim_enabled:
            self.articulation.set_joint_drive_targets(out, self.joints[:3], self.active_joint_indices[:3])
        else:
            for i, joint in enumerate(self.joints[:3]):
                joint._objs[0].drive_target = t32[0, i : i + 1]
        return self._with_hold(out)

    def put_back(self, rows: list[int], poses: np.ndarray) -> None:
        """Sub-envs ``rows`` stand at planar ``poses`` (their rows of an (N, 3) array), at rest, with those
        poses as their planar drive targets."""
        qpos = self.articulation.get_qpos().clone()
        cols = self.active_joint_indices[:3]
        idx = torch.as_tensor(rows, device=qpos.device)
        qpos[idx[:, None], cols] = torch.from_numpy(poses[rows]).to(qpos.device, qpos.dtype)
        self.articulation.set_qpos(qpos)
        self.articulation.set_qvel(torch.zeros_like(qpos))
        self.articulation.set_joint_drive_targets(qpos[:, cols], self.joints[:3], cols)

    def set_action(self, action: torch.Tensor):
        stop, forward, turn = self._decode(action)
        q = self.host_qpos()
        p = q.astype(np.float64)  # targets are computed as exactly as the pose allows
        held = stop if self.frozen is None else stop | self.frozen  # STOP, or an ended episode: stay put
        forward, turn = np.where(held, 0.0, forward), np.where(held, 0.0, turn)
        target = p.copy()
        c, s = np.cos(p[:, 2]), np.sin(p[:, 2])
        if self.perturb is None:
            target[:, 0] += forward * c
            target[:, 1] += forward * s
            moving = forward > 0
        else:
            forward, across, turn = self.perturb(forward, turn, ~held)
            target[:, 0] += forward * c - across * s
            target[:, 1] += forward * s + across * c
            moving = (forward != 0) | (across != 0)
        target[:, 2] += turn
        if self._reseat_yaw(p, target):
            q = self.host_qpos()
        self.command = NavCommand(p, stop, forward, turn, target)  # limit returns a new array
        if self.limit is not None:
            target = self.limit(p, target, moving)
        self._start_qpos = self._with_hold(torch.from_numpy(q.copy()).to(self.device))
        self._target_qpos = self._set_host_targets(target)

    def _reseat_yaw(self, pose: np.ndarray, target: np.ndarray) -> bool:
        """Where a yaw target passes +-YAW_RESEAT, turn the yaw joint's position and the target by a full
        turn back toward zero (the same orientation; ``pose`` and ``target`` rows change in place).
        Whether any did."""
        rows = np.flatnonzero(np.abs(target[:, 2]) > YAW_RESEAT)
        if len(rows) == 0:
            return False
        shift = -2 * math.pi * np.sign(target[rows, 2])
        pose[rows, 2] += shift
        target[rows, 2] += shift
        qpos = self.articulation.get_qpos().clone()
        yaw = self.active_joint_indices[2]
        qpos[rows, yaw] += torch.from_numpy(shift).to(qpos.device, qpos.dtype)
        self.articulation.set_qpos(qpos)
        return True


@dataclass
class NavBaseControllerConfig(PDJointPosControllerConfig):
    """``joint_names``: the planar x, y, yaw joints, then any joints held still at ``hold`` (an arm's tuck
    pose, a torso, a head: their drive targets never change)."""

    mode: str = "discrete"
    forward_step: float = 0.25
    turn_deg: float = 30.0
    hold: tuple[float, ...] = ()
    controller_cls = NavBaseController


def action_help() -> str:
    return "discrete actions are " + ", ".join(f"{k}={v}" for k, v in ACTIONS.items())


class NavAgent:
    """What the navigation task asks of a robot, mixed into a ManiSkill agent with one
    :class:`NavBaseController` per control mode: its row in ``biovln_ms.robots.ROBOTS``, its head camera
    link, planar poses in and out."""

    robot_id: str  # its ROBOTS row
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
            mode: NavBaseControllerConfig(
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
