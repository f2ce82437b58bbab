"""Whether Fetch's gripper reaches an instrument's interaction point from where its base stopped, and
the ``reachable`` / ``reach_success`` measures the navigation env reports for Fetch.

The rule (docs: envs and variants, "Reachability"):

* **Kinematics**: SAPIEN's pinocchio model of Fetch's articulation (ManiSkill's URDF: the env's own
  articulation, or one loaded into a scratch physics-only scene by :meth:`FetchArm.load`): its forward
  kinematics and Jacobians. The base is fixed at the planar pose where it stopped; the torso lift and the
  seven arm joints are free within the URDF's limits (the three roll joints are continuous); the head stays
  level and the gripper is open. The IK is a bounded least-squares problem solved by scipy's SLSQP with
  the pinocchio Jacobian as gradient: the TCP's squared distance to the point, plus a penalty once the
  approach axis leaves a cone of ``APPROACH_CONE_DEG`` about -f (the roll is free), from each of the
  ``SEEDS`` in turn until one gives a collision-free configuration within the tolerances. (Pinocchio's
  own CLIK, ``compute_inverse_kinematics``, needs one full target orientation and ignores the joint limits,
  so it misses standoffs that a free roll within the limits reaches.)
* **Reach**: ``gripper_link``'s origin (between the fingertips: ManiSkill's Fetch TCP) within
  ``POSITION_TOLERANCE`` (2 cm) of the interaction point, and its approach axis (the link's +x, out of the
  palm) within ``APPROACH_TOLERANCE_DEG`` (30 degrees) of the face's inward normal -f.
* **No collision** (a geometric check, no physics): the arm links' convex collision meshes against boxes:
  every object's Zone-1 box (its bounding box: conservative for the coacd-shaped ones), every wall, and the
  floor. The gripper and its fingers may touch the target instrument (grasping it is the point); nothing
  else may touch anything. No self-collision between an arm link and the rest of the robot, or between two
  arm links that no joint joins (the SRDF's pairs excepted). Two convex shapes collide when their
  intersection holds a ball of radius ``PENETRATION`` (2 mm): a linear programme (scipy's HiGHS) for each
  pair that neither bounding spheres nor face planes separate.

The base itself is the navigation's business: free space keeps its footprint clear of every body.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path
from typing import Callable, Sequence

import numpy as np
import sapien
from scipy.optimize import linprog, minimize
from scipy.spatial import ConvexHull

from biovln_ms.agents.robots.fetch_nav import BASE_JOINTS, TUCK
from biovln_ms.catalog import load_catalog
from biovln_ms.errors import BioVLNError
from biovln_ms.geometry.zones import rot2
from biovln_ms.metrics.measures import Measure, Metric, register_measure
from biovln_ms.scene.shell import wall_spans
from biovln_ms.scene.spec import ObjectSpec, SceneSpec

POSITION_TOLERANCE = 0.02  # m: the TCP within this of the interaction point
APPROACH_TOLERANCE_DEG = 30.0  # the approach axis within this of the face's inward normal
APPROACH_CONE_DEG = 25.0  # the IK's free cone (inside the tolerance, so a solution on its edge passes)
CONE_WEIGHT = 1.0  # m^2 per unit of (cos cone - cos angle)^2 outside the cone
PENETRATION = 0.002  # m: two convex shapes collide when their intersection holds a ball this large
GRIPPER_OPEN = 0.05  # m, each finger joint (the URDF's upper limit)
TCP_LINK = "gripper_link"
ARM_ROOT = "shoulder_pan_link"  # it and its descendants are the arm
FREE_JOINTS = (
    "torso_lift_joint",
    "shoulder_pan_joint",
    "shoulder_lift_joint",
    "upperarm_roll_joint",
    "elbow_flex_joint",
    "forearm_roll_joint",
    "wrist_flex_joint",
    "wrist_roll_joint",
)
GRASPING_LINKS = ("gripper_link", "l_gripper_finger_link", "r_gripper_finger_link")  # may touch the target
#: the IK's starting configurations, in order (joints not named: the tuck pose's): the tuck pose; the arm
#: reaching forward, torso half up; reaching up, torso up; reaching down, torso down
SEEDS = (
    {},
    {
        "torso_lift_joint": 0.2,
        "shoulder_pan_joint": 0.0,
        "shoulder_lift_joint": 0.3,
        "upperarm_roll_joint": 0.0,
        "elbow_flex_joint": 1.2,
        "forearm_roll_joint": 0.0,
        "wrist_flex_joint": -0.6,
        "wrist_roll_joint": 0.0,
    },
    {
        "torso_lift_joint": 0.38,
        "shoulder_pan_joint": 0.0,
        "shoulder_lift_joint": -0.6,
        "upperarm_roll_joint": 0.0,
        "elbow_flex_joint": 1.0,
        "forearm_roll_joint": 0.0,
        "wrist_flex_joint": -0.4,
        "wrist_roll_joint": 0.0,
    },
    {
        "torso_lift_joint": 0.0,
        "shoulder_pan_joint": 0.0,
        "shoulder_lift_joint": 0.9,
        "upperarm_roll_joint": 0.0,
        "elbow_flex_joint": -1.0,
        "forearm_roll_joint": 0.0,
        "wrist_flex_joint": 0.3,
        "wrist_roll_joint": 0.0,
    },
)
FETCH_DOF = len(BASE_JOINTS) + len(TUCK)


def _fetch_dir() -> Path:
    import mani_skill

    return Path(mani_skill.__file__).parent / "assets" / "robots" / "fetch"


class ReachError(BioVLNError):
    """A goal without an interaction point, or a robot without an arm model."""


# --- obstacles -----------------------------------------------------------------------------------
@dataclass(frozen=True)
class Box:
    """An obstacle: a box of half extents ``half`` at ``center`` (world, metres), turned ``yaw`` about Z."""

    name: str
    center: tuple[float, float, float]
    yaw: float
    half: tuple[float, float, float]

    def planes(self) -> np.ndarray:
        """(6, 4) rows (n, d) with n . x + d <= 0 inside, n unit."""
        r = np.eye(3)
        r[:2, :2] = rot2(self.yaw)
        n = np.vstack([r.T, -r.T])
        c, h = np.asarray(self.center), np.asarray(self.half)
        return np.column_stack([n, -(n @ c) - np.concatenate([h, h])])

    def corners(self) -> np.ndarray:
        """(8, 3) corners in the world."""
        signs = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], float)
        local = signs * np.asarray(self.half)
        local[:, :2] = local[:, :2] @ rot2(self.yaw).T
        return local + np.asarray(self.center)

    def distance(self, p: np.ndarray) -> float:
        """Distance from point ``p`` to the box (0 inside)."""
        local = np.asarray(p, float) - np.asarray(self.center)
        local[:2] = local[:2] @ rot2(self.yaw)
        return float(np.linalg.norm(np.maximum(np.abs(local) - np.asarray(self.half), 0.0)))


def object_box(o: ObjectSpec) -> Box:
    """An object's Zone-1 box (its bounding box) in the world."""
    return Box(o.id, tuple(o.position), o.yaw, tuple(s / 2 for s in o.size))


def scene_boxes(spec: SceneSpec) -> list[Box]:
    """Every object's Zone-1 box and every wall of ``spec`` (the walls as the simulator builds them)."""
    boxes = [object_box(o) for o in spec.objects()]
    for w, (a, b) in zip(spec.walls, wall_spans(spec)):
        n = np.asarray(w.interior, float)
        centre = (a + b) / 2 - n * w.thickness / 2
        yaw = math.atan2(b[1] - a[1], b[0] - a[0])
        half = (float(np.linalg.norm(b - a)) / 2, w.thickness / 2, w.height / 2)
        boxes.append(Box(w.id, (float(centre[0]), float(centre[1]), w.height / 2), yaw, half))
    return boxes


def interaction_point(o: ObjectSpec) -> np.ndarray:
    """The catalog's interaction point of ``o``'s category, in the world (3,); a one-line ReachError when the
    category has none."""
    asset = load_catalog().get(o.category)
    if asset.interaction is None:
        raise ReachError(
            f"category '{o.category}' has no interaction point",
            field="interaction",
            fix=f"add an 'interaction' entry to '{o.category}' in assets/catalog.json",
        )
    p = np.asarray(asset.interaction.point, float)
    xy = np.asarray(o.position[:2], float) + rot2(o.yaw) @ p[:2]
    return np.array([xy[0], xy[1], o.position[2] + p[2]])


def object_face(o: ObjectSpec) -> np.ndarray:
    """The world-space operational face normal f (2,) of ``o``."""
    if o.face is None:
        raise ReachError(f"object '{o.id}' has no operational face", field="face")
    return np.asarray(o.face, float)


# --- the arm -------------------------------------------------------------------------------------
@dataclass(frozen=True)
class ReachResult:
    """The verdict for one base pose and one point. ``qpos``: every active joint (ManiSkill's order), the
    reaching configuration when ``reachable``, else the closest attempt (None when no IK ran).
    ``blocked_by``: what the first in-tolerance configuration collided with (``reason`` "collision")."""

    reachable: bool
    reason: str  # "reached", "out of reach" (no configuration within the tolerances), "collision"
    position_error: float  # m, of the closest attempt
    approach_deg: float  # its approach axis against -f
    qpos: np.ndarray | None = None
    blocked_by: str = ""


@dataclass
class _Hull:
    """One convex collision shape in its link's frame."""

    vertices: np.ndarray  # (V, 3)
    planes: np.ndarray  # (F, 4) unit normals, n . x + d <= 0 inside
    centre: np.ndarray  # (3,) bounding sphere
    radius: float


class FetchArm:
    """Fetch's arm as the reach check sees it: SAPIEN's pinocchio model of an articulation loaded from
    ManiSkill's Fetch URDF, and its links' convex collision meshes."""

    def __init__(self, articulation: sapien.physx.PhysxArticulation) -> None:
        self.model = articulation.create_pinocchio_model()
        joints, links = articulation.get_active_joints(), articulation.get_links()
        prefix = links[0].name.removesuffix("root")  # ManiSkill's "scene-0-fetch_nav_"; none from the URDF

        def name(entity) -> str:
            return entity.name.removeprefix(prefix)

        self.joint_names = [name(j) for j in joints]
        self.link_names = [name(link) for link in links]
        fetch = self.joint_names[: len(BASE_JOINTS)] == list(BASE_JOINTS) and TCP_LINK in self.link_names
        if not fetch or not np.allclose(articulation.get_root_pose().to_transformation_matrix(), np.eye(4)):
            raise ReachError(
                "the articulation is not Fetch rooted at the world origin (planar joints = world x, y, yaw)",
                field="robot_uids",
                fix="reachability is defined for robot_uids='fetch' only",
            )
        limits = np.array([j.get_limits()[0] for j in joints], float)
        self.lower, self.upper = limits[:, 0], limits[:, 1]
        self.free = np.array([self.joint_names.index(n) for n in FREE_JOINTS])
        lo, hi = self.lower[self.free], self.upper[self.free]
        finite = np.isfinite(lo) & np.isfinite(hi)  # the roll joints are continuous: any angle will do
        self.bounds = list(zip(np.where(finite, lo, -2 * math.pi), np.where(finite, hi, 2 * math.pi)))
        self.tcp = self.link_names.index(TCP_LINK)
        self.hulls = {i: [_hull(s) for s in link.get_collision_shapes()] for i, link in enumerate(links)}
        self.hulls = {i: h for i, h in self.hulls.items() if h}
        parent = {
            name(j.get_child_link()): name(j.get_parent_link())
            for j in articulation.get_joints()
            if j.get_parent_link() is not None
        }
        arm = {ARM_ROOT}
        for name in self.link_names:  # links are listed parents first
            if parent.get(name) in arm:
                arm.add(name)
        self.arm = [i for i in self.hulls if self.link_names[i] in arm]
        skip = {frozenset(p) for p in parent.items()} | _srdf_pairs()
        names = self.link_names
        self.self_pairs = [
            (a, b)
            for a in self.arm
            for b in self.hulls
            if b != a and (b not in self.arm or b > a) and frozenset((names[a], names[b])) not in skip
        ]
        self.grasping = {names.index(n) for n in GRASPING_LINKS}
        self.seeds = [self._seed(joints) for joints in SEEDS]
        # the arm's length: the distances between its joints' origins, shoulder pan to TCP, add up
        ancestors = _chain_to(parent)
        chain = [n for n in names if n in arm and n in ancestors]
        self.model.compute_forward_kinematics(self.seeds[0])
        origins = [self._link_pose(names.index(n)).p for n in chain]
        self.arm_length = float(sum(np.linalg.norm(b - a) for a, b in zip(origins, origins[1:])))
        # the shoulder pan's origin in the base frame with the torso down and up
        self.shoulder = tuple(
            self.tcp_pose(self._with_torso(self.seeds[0], t), names.index(ARM_ROOT)).p
            for t in (self.lower[self.free[0]], self.upper[self.free[0]])
        )

    @classmethod
    def load(cls) -> FetchArm:
        """From ManiSkill's Fetch URDF in a scratch physics-only scene (no renderer; visuals dropped)."""
        return _standalone()

    # --- kinematics --------------------------------------------------------------------------------
    def _seed(self, joints: dict[str, float]) -> np.ndarray:
        q = np.zeros(len(self.joint_names))
        for name, v in {**TUCK, **joints}.items():
            q[self.joint_names.index(name)] = v
        for name in ("l_gripper_finger_joint", "r_gripper_finger_joint"):
            q[self.joint_names.index(name)] = GRIPPER_OPEN
        return q

    def _with_torso(self, q: np.ndarray, torso: float) -> np.ndarray:
        q = q.copy()
        q[self.free[0]] = torso
        return q

    def _link_pose(self, index: int) -> sapien.Pose:
        """World pose of link ``index`` after ``compute_forward_kinematics`` (the root is the origin)."""
        return self.model.get_link_pose(index)

    def tcp_pose(self, qpos: np.ndarray, link: int | None = None) -> sapien.Pose:
        """The TCP's (``gripper_link``'s), or link ``link``'s, world pose at joint positions ``qpos``."""
        self.model.compute_forward_kinematics(np.asarray(qpos, float))
        return self._link_pose(self.tcp if link is None else link)

    def _within_reach(self, base: np.ndarray, point: np.ndarray) -> bool:
        """Whether ``point`` lies within the arm's length of the shoulder pan's origin at some torso height
        (a necessary condition, checked before any IK)."""
        c, s = math.cos(base[2]), math.sin(base[2])
        lo, hi = (
            np.array([base[0] + c * p[0] - s * p[1], base[1] + s * p[0] + c * p[1], p[2]])
            for p in self.shoulder
        )
        seg = hi - lo
        t = np.clip(np.dot(point - lo, seg) / max(np.dot(seg, seg), 1e-12), 0.0, 1.0)
        return float(np.linalg.norm(point - (lo + t * seg))) <= self.arm_length + POSITION_TOLERANCE

    def _ik(self, q0: np.ndarray, point: np.ndarray, inward: np.ndarray) -> np.ndarray:
        """The free joints minimising the TCP's squared distance to ``point`` plus the cone penalty (module
        docstring), from ``q0``, within the joint limits."""
        cone = math.cos(math.radians(APPROACH_CONE_DEG))
        free = self.free

        def cost(z: np.ndarray) -> tuple[float, np.ndarray]:
            q = q0.copy()
            q[free] = z
            self.model.compute_forward_kinematics(q)
            m = self.model.get_link_pose(self.tcp).to_transformation_matrix()
            r, e = m[:3, :3], m[:3, 3] - point
            jac = self.model.compute_single_link_local_jacobian(q, self.tcp)[:, free]  # link frame (v, w)
            out = max(0.0, cone - float(r[:, 0] @ inward))  # the approach axis x outside the cone
            grad = 2 * (r @ jac[:3]).T @ e - 2 * CONE_WEIGHT * out * (
                (r @ jac[3:]).T @ np.cross(r[:, 0], inward)
            )
            return float(e @ e + CONE_WEIGHT * out * out), grad

        q = q0.copy()
        q[free] = minimize(cost, q0[free], jac=True, method="SLSQP", bounds=self.bounds).x
        return q

    def reach(
        self,
        base: Sequence[float],
        point: Sequence[float],
        face: Sequence[float],
        boxes: Sequence[Box],
        target: str,
    ) -> ReachResult:
        """Whether the gripper reaches ``point`` (world, 3) on a face of outward normal ``face`` (2,) with the
        base at planar pose ``base`` (x, y, yaw), clear of ``boxes`` (``target``: the instrument's box name,
        which the gripper may touch); see the module's docstring for the rule."""
        base, point = np.asarray(base, float), np.asarray(point, float)
        inward = -np.array([face[0], face[1], 0.0]) / np.linalg.norm(face)
        if not self._within_reach(base, point):
            return ReachResult(False, "out of reach", math.inf, math.nan)
        near = [b for b in boxes if b.distance(base_point(base)) <= self.arm_length + 0.5]
        best: tuple[float, float, np.ndarray] | None = None
        blocked = ""
        for seed in self.seeds:
            q0 = seed.copy()
            q0[: len(BASE_JOINTS)] = base
            q = self._ik(q0, point, inward)
            tcp = self.tcp_pose(q)
            err = float(np.linalg.norm(tcp.p - point))
            axis = tcp.to_transformation_matrix()[:3, 0]
            angle = math.degrees(math.acos(float(np.clip(axis @ inward, -1.0, 1.0))))
            if best is None or err < best[0]:
                best = (err, angle, q)
            if err > POSITION_TOLERANCE or angle > APPROACH_TOLERANCE_DEG:
                continue
            hit = self.collision(q, near, target)
            if not hit:
                return ReachResult(True, "reached", err, angle, q)
            blocked = blocked or hit
        err, angle, q = best
        return ReachResult(False, "collision" if blocked else "out of reach", err, angle, q, blocked)

    # --- collision -------------------------------------------------------------------------------
    def _world_hulls(self, qpos: np.ndarray) -> dict[int, list[_Hull]]:
        self.model.compute_forward_kinematics(np.asarray(qpos, float))
        out = {}
        for i, hulls in self.hulls.items():
            m = self._link_pose(i).to_transformation_matrix()
            r, p = m[:3, :3], m[:3, 3]
            world = []
            for h in hulls:
                n = h.planes[:, :3] @ r.T
                world.append(
                    _Hull(
                        h.vertices @ r.T + p,
                        np.column_stack([n, h.planes[:, 3] - n @ p]),
                        r @ h.centre + p,
                        h.radius,
                    )
                )
            out[i] = world
        return out

    def collision(self, qpos: np.ndarray, boxes: Sequence[Box], target: str) -> str:
        """What the robot at ``qpos`` collides with: a box's name, "floor", "self: a/b", or "" when free."""
        world = self._world_hulls(qpos)
        names = self.link_names
        for i in self.arm:
            for h in world[i]:
                if h.vertices[:, 2].min() < -PENETRATION:
                    return f"floor ({names[i]})"
                for b in boxes:
                    if b.name == target and i in self.grasping:
                        continue
                    if b.distance(h.centre) <= h.radius and _overlap(
                        h.planes, b.planes(), h.vertices, b.corners()
                    ):
                        return f"{b.name} ({names[i]})"
        for a, b in self.self_pairs:
            for ha in world[a]:
                for hb in world[b]:
                    close = np.linalg.norm(ha.centre - hb.centre) <= ha.radius + hb.radius
                    if close and _overlap(ha.planes, hb.planes, ha.vertices, hb.vertices):
                        return f"self ({names[a]}/{names[b]})"
        return ""


def base_point(base: np.ndarray) -> np.ndarray:
    """The base's centre on the floor (3,) of a planar pose."""
    return np.array([base[0], base[1], 0.0])


def _overlap(p: np.ndarray, q: np.ndarray, pv: np.ndarray, qv: np.ndarray) -> bool:
    """Whether two convex sets, given by unit-normal half-spaces (n . x + d <= 0) ``p`` / ``q`` and vertices
    ``pv`` / ``qv``, share a ball of radius ``PENETRATION``. A face plane with the other set's vertices all
    that far outside it separates them; else the largest ball in their intersection (its Chebyshev centre)
    is one linear programme."""
    if ((qv @ p[:, :3].T + p[:, 3]).min(axis=0) > -PENETRATION).any():
        return False
    if ((pv @ q[:, :3].T + q[:, 3]).min(axis=0) > -PENETRATION).any():
        return False
    planes = np.vstack([p, q])
    a = np.column_stack([planes[:, :3], np.ones(len(planes))])
    res = linprog(
        [0.0, 0.0, 0.0, -1.0], A_ub=a, b_ub=-planes[:, 3], bounds=[(None, None)] * 3 + [(None, 1.0)]
    )
    return res.status == 0 and -res.fun > PENETRATION


def _hull(shape) -> _Hull:
    """A convex collision shape in its link's frame."""
    local = shape.get_local_pose().to_transformation_matrix()
    v = (np.asarray(shape.get_vertices(), float) * np.asarray(shape.get_scale(), float)) @ local[:3, :3].T
    v += local[:3, 3]
    eq = ConvexHull(v).equations
    centre = (v.min(0) + v.max(0)) / 2
    return _Hull(v, eq, centre, float(np.linalg.norm(v - centre, axis=1).max()))


def _chain_to(parent: dict[str, str], link: str = TCP_LINK) -> set[str]:
    """The links from ``link`` up to the root."""
    out = {link}
    while link in parent:
        link = parent[link]
        out.add(link)
    return out


def _srdf_pairs() -> set[frozenset[str]]:
    """The link pairs ManiSkill's Fetch SRDF exempts from self-collision."""
    root = ET.parse(_fetch_dir() / "fetch.srdf").getroot()
    return {frozenset((e.get("link1"), e.get("link2"))) for e in root.iter("disable_collisions")}


@lru_cache(maxsize=1)
def _standalone() -> FetchArm:
    scene = sapien.Scene([sapien.physx.PhysxCpuSystem()])
    loader = scene.create_urdf_loader()
    loader.fix_root_link = True
    builders, _, _ = loader.parse(str(_fetch_dir() / "fetch.urdf"))
    for link in builders[0].link_builders:
        link.visual_records = []  # a physics-only scene has no renderer for them
    arm = FetchArm(builders[0].build())
    arm._scene = scene  # keeps the articulation alive
    return arm


# --- the measures ----------------------------------------------------------------------------------
ReachSolver = Callable[[int, np.ndarray], tuple[ReachResult, int]]


@register_measure
class Reachable(Measure):
    """At STOP, Fetch's gripper reaches the interaction point of one of the episode's goals from the final
    base pose (this module's rule); False before a STOP and for an episode that ends without one. ``qpos``
    keeps the reaching configuration (NaN otherwise) and ``goal`` the index of the goal reached (-1 none).
    The env binds ``solver`` (sub-env, pose (x, y, yaw)) -> (result, goal index)."""

    uuid = "reachable"
    metric = Metric("reachable", required=False)
    dtype = bool
    dependencies = ("stopped",)
    state_names = ("value", "qpos", "goal")

    def __init__(self, n: int, cfg) -> None:
        super().__init__(n, cfg)
        self.qpos = np.full((n, FETCH_DOF), math.nan)
        self.goal = np.full(n, -1, np.int64)
        self.solver: ReachSolver | None = None

    def reset(self, ctx, s, m, idx):
        self.value[idx], self.qpos[idx], self.goal[idx] = False, math.nan, -1

    def update(self, ctx, s, m, idx):
        for i in np.arange(ctx.n)[idx][m["stopped"][idx]].tolist():
            result, goal = self.solver(i, np.array([*s.position[i], s.yaw[i]]))
            self.value[i], self.goal[i] = result.reachable, goal if result.reachable else -1
            self.qpos[i] = result.qpos if result.reachable else math.nan


def reach_goals(
    arm: FetchArm, spec: SceneSpec, object_ids: Sequence[str], pose: np.ndarray
) -> tuple[ReachResult, int]:
    """The first goal (of ``object_ids``, nearest first) whose interaction point the gripper reaches from
    planar ``pose`` in ``spec``, and its index in ``object_ids``; else the nearest goal's verdict and -1."""
    boxes = scene_boxes(spec)
    objs = [spec.get(oid) for oid in object_ids]
    points = [interaction_point(o) for o in objs]
    order = sorted(range(len(objs)), key=lambda j: float(np.hypot(*(points[j][:2] - pose[:2]))))
    first = None
    for j in order:
        result = arm.reach(pose, points[j], object_face(objs[j]), boxes, objs[j].id)
        if result.reachable:
            return result, j
        first = first or result
    return first, -1
