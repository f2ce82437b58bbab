"""Navigation locomotion (paper §3.2): one ManiSkill controller, used by every robot, that turns an action
into a planar move and reports what the move did.

Control modes (``env.control_mode``):

* ``discrete``: ``Discrete(4)`` — 0 STOP, 1 FORWARD ``forward_step``, 2 TURN_LEFT, 3 TURN_RIGHT ``turn_deg``;
* ``continuous``: ``Box(-1, 1, (3,))`` — [forward, turn, stop]: forward (a0 + 1) / 2 · step, turn a1 · turn
  angle, STOP when a2 > 0.

A step is :meth:`LocomotionController.begin_step` (which sub-envs are held, the actuation noise's clock),
ManiSkill's ``set_action`` (decode, actuation noise of :mod:`biovln_ms.noise`, the drive target cut before an
obstacle the straight path would cross), the physics substeps, then :meth:`LocomotionController.end_step`:
a body that went through or deep into an obstacle is put back where the move started
(:mod:`biovln_ms.geometry.motion`), and without sliding a move that missed its target leaves the robot where
it started, turned (Habitat's ``allow_sliding=False``). ``end_step`` returns the :class:`Move` the task's
measures read. The planar joints (x, y, yaw) have a stiff PD position drive, so a commanded pose is reached
exactly when free; a robot's other joints (Fetch's arm) are held at fixed targets by the same controller.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import torch
from gymnasium import spaces
from mani_skill.agents.controllers import PDJointPosController, PDJointPosControllerConfig

from biovln_ms.errors import BioVLNError
from biovln_ms.geometry.motion import SweptMotion
from biovln_ms.noise import actuation_errors, actuation_uniforms
from biovln_ms.scene.rules import floor_polygon
from biovln_ms.sim.footprints import collision_footprints

ACTIONS = {0: "STOP", 1: "FORWARD", 2: "TURN_LEFT", 3: "TURN_RIGHT"}
CONTROL_MODES = ("discrete", "continuous")
#: the longest FORWARD (m) a task may configure: the swept-motion checks keep the body within
#: ``biovln_ms.geometry.motion.ALLOWANCE`` of contact up to it (tested)
MAX_FORWARD_STEP = 2.0
#: a yaw drive target beyond this (rad) re-seats the yaw joint by a turn first: PhysX keeps the joint's
#: position within +-2 pi, so a target past it would make the drive spin the long way round
YAW_RESEAT = 1.5 * math.pi
#: a move that ends farther than this (m) from its target was blocked (no sliding)
SLIDE_TOLERANCE = 0.01
#: steps of actuation noise drawn at once per sub-env: a generator's first draw after a render costs far
#: more than the next ones (cold caches), so the draws of the next steps come with it (the same numbers)
ACTUATION_CHUNK = 32


class ActionError(BioVLNError):
    """An action outside the control mode's action space."""


def action_help(mode: str = "discrete") -> str:
    if mode == "continuous":
        return (
            "continuous actions are [forward, turn, stop] in [-1, 1]: forward (a0+1)/2 * step, "
            "turn a1 * turn angle, stop when a2 > 0"
        )
    return "discrete actions are " + ", ".join(f"{k}={v}" for k, v in ACTIONS.items())


#: torch dtypes of actions (NumPy's are kinds "i", "u", "f")
_TORCH_NUMBERS = {torch.int8, torch.int16, torch.int32, torch.int64, torch.uint8}
_TORCH_NUMBERS |= {torch.float16, torch.bfloat16, torch.float32, torch.float64}


def as_action(action, mode: str, n: int):
    """``action`` as ManiSkill's ``step`` takes it: what gymnasium users pass for ``Discrete(4)`` (``2``,
    ``np.int64(2)``, 0-d arrays and tensors, lists) as an (N,)-shaped tensor, arrays and tensors as they
    are; ``None`` (ManiSkill's no action) stays None. Anything outside the control mode's action space, of
    another type or shape, is a one-line ActionError before the step starts."""
    if action is None:
        return None
    if isinstance(action, dict):
        same = set(action) == {"control_mode", "action"} and isinstance(action["control_mode"], str)
        if not same or action["control_mode"] != mode:
            raise ActionError(
                f"a dict action {sorted(map(str, action))} switches ManiSkill's controller; this env's "
                f"control mode is '{mode}'",
                field="action",
                fix=f"pass the action itself (control_mode= at gym.make for another); {action_help(mode)}",
            )
        action = action["action"]
    if isinstance(action, (int, float, np.generic, list, tuple)) and not isinstance(action, (bool, np.bool_)):
        try:
            array = np.asarray(action)
        except Exception:  # noqa: BLE001 - ragged or unconvertible: refused below as not numbers
            array = np.asarray(None)
        _check_action(array, action, mode, n)
        action = torch.as_tensor(array)
    elif isinstance(action, np.ndarray):
        _check_action(action, action, mode, n)
    elif isinstance(action, torch.Tensor):
        if action.dtype not in _TORCH_NUMBERS:
            _refuse(action, f"of dtype {action.dtype}", mode)
        _check_action(action.detach().cpu().to(torch.float64).numpy(), action, mode, n)
    else:
        _refuse(action, f"of type {type(action).__name__}", mode)
    return action.reshape(1) if action.ndim == 0 else action


def _refuse(action, why: str, mode: str):
    text = " ".join(repr(action).split())  # one line, whatever the array
    text = text if len(text) <= 80 else text[:77] + "..."
    raise ActionError(f"action {text} is {why}", field="action", fix=action_help(mode))


def _check_action(a: np.ndarray, action, mode: str, n: int) -> None:
    """The action's values ``a``: numbers (no booleans) of the mode's shape, finite, in the action space."""
    if a.dtype.kind not in "iuf":
        kind = {"b": "a boolean", "O": "not an array of numbers"}.get(a.dtype.kind, "not a number")
        _refuse(action, kind, mode)
    if mode == "discrete":
        shapes = ((), (1,)) if n == 1 else ((n,),)
        if a.shape not in shapes:
            _refuse(action, f"of shape {a.shape}, not {' or '.join(map(str, shapes))}", mode)
        if not np.isfinite(a).all() or (a != np.round(a)).any():
            _refuse(action, f"not {n} integer(s)", mode)
        if ((a < 0) | (a >= len(ACTIONS))).any():
            _refuse(action, "outside Discrete(4)", mode)
        return
    shapes = ((3,), (1, 3)) if n == 1 else ((n, 3),)
    if a.shape not in shapes:
        _refuse(action, f"of shape {a.shape}, not {' or '.join(map(str, shapes))}", mode)
    if not np.isfinite(a).all() or np.abs(a).max() > 1.0 + 1e-6:
        _refuse(action, "outside Box(-1, 1, (3,))", mode)


def swept_motion(spec, radius: float) -> SweptMotion:
    """The swept-motion checks of a scene spec for the footprint disc (``radius``) of the robot that moves:
    the bound on how deep its body goes is its own, whatever robot the scene was made for."""
    return SweptMotion(floor_polygon(spec), collision_footprints(spec), radius)


@dataclass
class NavCommand:
    """The last command, per sub-env: the pose it started from and what was asked (host arrays)."""

    start_pose: np.ndarray  # (N, 3) float64
    stop: np.ndarray  # (N,) bool
    forward: np.ndarray  # (N,) m along the heading, float64 (with actuation noise, the noisy one)
    turn: np.ndarray  # (N,) rad, float64 (idem)
    target: np.ndarray  # (N, 3) the pose the move aims at, before the swept-motion cut


@dataclass
class Move:
    """What one step did, per sub-env: the measures' inputs (host arrays)."""

    pose: np.ndarray  # (N, 3) float64 planar pose after the step
    stop: np.ndarray  # (N,) bool: STOP was called
    forward: np.ndarray  # (N,) m commanded along the heading
    moved: np.ndarray  # (N,) m actually moved along the start heading


class LocomotionController(PDJointPosController):
    """Discrete or continuous navigation commands on the planar joints' stiff PD position drive; the
    config's held joints (after the three planar ones) keep fixed drive targets. The command arithmetic is
    NumPy on the host (a few numbers per sub-env; the drive targets go to the device)."""

    config: "LocomotionControllerConfig"
    actuation = 0.0  # actuation noise level (biovln_ms.noise), 0: exact moves
    sliding = True  # a blocked move slides along the obstacle (False: it stays where it started)
    motions: list[SweptMotion] | None = None  # per sub-env swept-motion checks (None: no checks)
    people = None  # the env's people (biovln_ms.tasks.people.EnvPeople): moves are cut at their bodies
    frozen: np.ndarray | None = None  # (N,) sub-envs whose episode has ended: their actions are ignored

    def _initialize_action_space(self):
        if self.config.mode == "discrete":
            self.single_action_space = spaces.Discrete(len(ACTIONS))
        else:
            self.single_action_space = spaces.Box(-1.0, 1.0, (3,), np.float32)

    def configure(self, forward_step: float, turn_deg: float, actuation: float = 0.0, sliding: bool = True):
        """The task's motion model: the distance of one FORWARD, the angle of one turn, the actuation noise
        level and whether a blocked move slides."""
        self.set_motion(forward_step, turn_deg)
        self.actuation, self.sliding = float(actuation), bool(sliding)
        n = self.scene.num_envs
        self.actuation_error = np.zeros((n, 3))  # the last step's (along, across, heading) error
        self._uniform_chunks: dict[int, tuple] = {}  # sub-env -> ((episode seed, first step), uniforms)

    def set_motion(self, forward_step: float, turn_deg: float) -> None:
        self.forward_step, self.turn = float(forward_step), math.radians(turn_deg)
        # per discrete action: stop, forward (m), turn (rad)
        self._table = np.array(
            [[1.0, 0.0, 0.0], [0.0, self.forward_step, 0.0], [0.0, 0.0, self.turn], [0.0, 0.0, -self.turn]]
        )

    def reset(self):
        super().reset()
        if not hasattr(self, "forward_step"):
            self.configure(self.config.forward_step, self.config.turn_deg)
        n = self.scene.num_envs
        pose = self.host_qpos().astype(np.float64)
        self.command = NavCommand(pose, np.zeros(n, dtype=bool), np.zeros(n), np.zeros(n), pose)
        if self.config.hold:
            self._hold = torch.tensor(self.config.hold, dtype=torch.float32, device=self.device)
            held = self._hold[None]  # one row: the sub-envs being reset take it on the GPU
            self.articulation.set_joint_drive_targets(held, self.joints[3:], self.active_joint_indices[3:])

    def _initialize_joints(self):
        super()._initialize_joints()
        self._joint_columns = self.active_joint_indices[:3].cpu().numpy()  # the planar joints' qpos columns

    # --- a step ----------------------------------------------------------------------------------
    def begin_step(self, frozen: np.ndarray, episode_seed: np.ndarray, elapsed_steps: torch.Tensor) -> None:
        """Before ``set_action``: the sub-envs whose episode has ended (held still), and each sub-env's
        episode seed and step, which key its actuation noise so a recorded episode replays exactly."""
        self.frozen, self._episode_seed, self._elapsed_steps = frozen, episode_seed, elapsed_steps

    def set_action(self, action: torch.Tensor):
        stop, forward, turn = self._decode(action)
        q = self.host_qpos()
        p = q.astype(np.float64)  # targets are computed as exactly as the pose allows
        held = stop if self.frozen is None else stop | self.frozen  # STOP, or an ended episode: stay put
        forward, turn = np.where(held, 0.0, forward), np.where(held, 0.0, turn)
        target = p.copy()
        c, s = np.cos(p[:, 2]), np.sin(p[:, 2])
        if not self.actuation > 0:
            target[:, 0] += forward * c
            target[:, 1] += forward * s
            moving = forward > 0
        else:
            forward, across, turn = self._perturb(forward, turn, ~held)
            target[:, 0] += forward * c - across * s
            target[:, 1] += forward * s + across * c
            moving = (forward != 0) | (across != 0)
        target[:, 2] += turn
        if self._reseat_yaw(p, target):
            q = self.host_qpos()
        self.command = NavCommand(p, stop, forward, turn, target)
        if self.motions is not None:
            target = self._limit_targets(p, target, moving)
        self._start_qpos = self._with_hold(torch.from_numpy(q.copy()).to(self.device))
        self._target_qpos = self._set_host_targets(target)

    def hold_still(self) -> None:
        """ManiSkill's no-action step (``step(None)``), instead of ``set_action``: the drive targets are the
        current pose, so the robot holds it for the step's physics; the step neither moves nor STOPs, and
        nothing of an earlier action carries over."""
        n = self.scene.num_envs
        pose = self.planar_pose()
        self.command = NavCommand(pose, np.zeros(n, dtype=bool), np.zeros(n), np.zeros(n), pose.copy())
        self.actuation_error = np.zeros((n, 3))
        self._start_qpos = self._with_hold(torch.from_numpy(self.host_qpos().copy()).to(self.device))
        self._target_qpos = self._set_host_targets(pose)

    def end_step(self) -> Move:
        """After the physics substeps: crossings undone, no sliding applied; what the step did."""
        cmd = self.command
        start = cmd.start_pose
        pose = self._undo_crossings(start, self.planar_pose())
        if not self.sliding:
            pose = self._no_sliding(cmd, pose)
        d = pose[:, :2] - start[:, :2]
        moved = d[:, 0] * np.cos(start[:, 2]) + d[:, 1] * np.sin(start[:, 2])
        return Move(pose, cmd.stop, cmd.forward, moved)

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

    def _perturb(self, forward: np.ndarray, turn: np.ndarray, acting: np.ndarray) -> tuple[np.ndarray, ...]:
        """Actuation noise: the executed (along, across, turn) of each sub-env's move, drawn from its episode
        seed and step (STOP and ended episodes move exactly: not at all)."""
        err = np.zeros((len(forward), 3))
        moving = np.flatnonzero(acting & ((forward > 0) | (turn != 0))).tolist()
        if moving:
            steps = self._elapsed_steps.tolist()
            for i in moving:
                u = self._actuation_uniforms(i, steps[i])
                err[i] = actuation_errors(u, float(forward[i]), float(turn[i]), self.actuation)
        self.actuation_error = err
        return forward + err[:, 0], err[:, 1], turn + err[:, 2]

    def _actuation_uniforms(self, i: int, step: int) -> list[float]:
        """Sub-env ``i``'s actuation uniforms at ``step`` (:func:`~biovln_ms.noise.actuation_uniforms`),
        drawn ``ACTUATION_CHUNK`` steps at a time and kept per sub-env."""
        seed, first = int(self._episode_seed[i]), step - step % ACTUATION_CHUNK
        chunk = self._uniform_chunks.get(i)
        if chunk is None or chunk[0] != (seed, first):
            chunk = ((seed, first), actuation_uniforms(seed, first, ACTUATION_CHUNK))
            self._uniform_chunks[i] = chunk
        return chunk[1][step - first]

    def _limit_targets(self, pose: np.ndarray, target: np.ndarray, moving: np.ndarray) -> np.ndarray:
        """Drive targets of moves cut before an obstacle the straight path would cross (no tunnelling at any
        step size), and with people, where the body would first touch a person's."""
        out = target.copy()
        for i in np.flatnonzero(moving).tolist():
            x, y = pose[i, :2].tolist()
            out[i, 0], out[i, 1] = self.motions[i].target(x, y, *target[i, :2].tolist())
            if self.people is not None:
                out[i, 0], out[i, 1] = self.people.cut(i, x, y, *out[i, :2].tolist())
        return out

    def _undo_crossings(self, start: np.ndarray, pose: np.ndarray) -> np.ndarray:
        """Sub-envs whose body went through or deep into an obstacle go back to where the move started (a
        blocked move); returns the poses after that."""
        if self.motions is None:
            return pose
        moved = np.flatnonzero((pose[:, :2] != start[:, :2]).any(1)).tolist()
        back = [i for i in moved if self.motions[i].crossed(*start[i, :2].tolist(), *pose[i, :2].tolist())]
        if not back:
            return pose
        self.put_back(back, start)
        return self.planar_pose()

    def _no_sliding(self, cmd: NavCommand, pose: np.ndarray) -> np.ndarray:
        """A move that did not reach its target (an obstacle stopped or deflected it) leaves the robot where
        it started, turned as the move turned it."""
        start, target = cmd.start_pose, cmd.target
        moved = (target[:, 0] != start[:, 0]) | (target[:, 1] != start[:, 1])
        off = np.hypot(pose[:, 0] - target[:, 0], pose[:, 1] - target[:, 1]) > SLIDE_TOLERANCE
        back = np.flatnonzero(moved & off).tolist()
        if not back:
            return pose
        stay = pose.copy()
        stay[back, :2] = start[back, :2]
        self.put_back(back, stay)
        return self.planar_pose()

    # --- joints ----------------------------------------------------------------------------------
    def host_qpos(self) -> np.ndarray:
        """(N, 3) float32 planar joint positions on the host: ManiSkill's ``qpos``, read straight from
        SAPIEN's articulation on the CPU backend (no tensor round trip)."""
        if self.scene.gpu_sim_enabled:
            return self.qpos[:, :3].cpu().numpy()
        return self.articulation._objs[0].qpos[None, self._joint_columns]

    def planar_pose(self) -> np.ndarray:
        """(N, 3) float64 planar poses."""
        return self.host_qpos().astype(np.float64)

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
class LocomotionControllerConfig(PDJointPosControllerConfig):
    """``joint_names``: the planar x, y, yaw joints, then any joints held still at ``hold`` (an arm's tuck
    pose, a torso, a head: their drive targets never change)."""

    mode: str = "discrete"
    forward_step: float = 0.25
    turn_deg: float = 30.0
    hold: tuple[float, ...] = ()
    controller_cls = LocomotionController
