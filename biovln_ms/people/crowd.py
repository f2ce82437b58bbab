"""One sub-env's technicians: routes on the robot's free space, schedules, waiting, and the robot's moves cut
at a person's body. Pure NumPy and shapely; every number of a crowd's state is in :meth:`Crowd.state`, so a
replay restored from it continues exactly.

A person is a disc of :data:`PERSON_RADIUS` (the SAPIEN figure fits inside it). People walk at their own
speed (uniform in :data:`SPEED_RANGE`) along shortest paths of the robot's navigable area (the robot's
footprint is at least their radius, so they never touch a wall, a piece of furniture or an instrument) to an
instrument's operational face, and stand at its Eq. 1 goal point (their body in its Zone 3) for a dwell time
(uniform in :data:`DWELL_RANGE`), then walk to another face that no one else has claimed. Each action step
lasts :func:`step_seconds`; people move in ticks of :data:`TICK` meanwhile, in index order. A tick's move
that would bring a body within :data:`GAP` of another person or of the robot (and closer than before) is
replaced by a sidestep of the same length (right first, then left) when that one is free, else the person
waits; after :data:`PATIENCE` seconds of waiting on one walk the person picks another face (no deadlock in a
narrow aisle). Draws are stateless, keyed by (episode seed, :data:`PEOPLE_STREAM`, person, visit), as the
actuation noise is (:mod:`biovln_ms.noise`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
import shapely
from shapely.geometry import LineString

from biovln_ms.errors import BioVLNError
from biovln_ms.geometry.navigation import NavGeometry, UnreachableError
from biovln_ms.people.body import PERSON_RADIUS

#: m/s: walking speeds; s: how long a person stands at a face
SPEED_RANGE = (0.8, 1.4)
DWELL_RANGE = (10.0, 40.0)
#: the robot's speeds that give an action step its duration (:func:`step_seconds`)
ROBOT_SPEED = 0.5  # m/s
ROBOT_TURN_RATE = 60.0  # degrees/s
#: s: people move in ticks of this within a step
TICK = 0.1
#: shortest paths a crowd keeps per scene (people walk between the same faces again and again)
MAX_CACHED_PATHS = 4096
#: m kept between a person's body and another's or the robot's
GAP = 0.1
#: m: at reset no person stands closer than this to the robot's body
START_CLEARANCE = 0.5
#: s of waiting on one walk after which a person walks to another face
PATIENCE = 8.0
#: degrees off the way ahead of a sidestep
SIDESTEP_DEG = 60.0
#: ``people=`` ranges over 0 to this
MAX_PEOPLE = 8
#: m: where a person absent from an episode is kept (a crowd holds ``people=`` slots; an episode carrying its
#: own count uses the first of them), far from any scene so no measure or cut sees them
ABSENT_XY = (1.0e4, 1.0e4)
#: waypoints a route keeps (a longer one is planned again from its last kept point)
ROUTE_POINTS = 48
#: the people's draws: default_rng([episode seed, PEOPLE_STREAM, person + 1, visit, purpose])
PEOPLE_STREAM = 0x70706C
STAND, WALK = 0, 1
#: what a person's wait is blamed on
_PERSON, _ROBOT = 1, 2

#: the measures an env with people reports besides its variant's (:mod:`biovln_ms.metrics.people_measures`)
PEOPLE_MEASURES = (
    "person_distance",
    "person_collision",
    "min_person_distance",
    "personal_space_rate",
    "person_collisions",
    "robot_wait_time",
    "people_wait_time",
    "mcr_people",
    "vrt_people",
    "occupied_stop",
)
#: a variant's fail measure and the one that extends it with a person collision (``person_collision_ends``)
PEOPLE_FAIL = {
    "failed_stop": "people_fail",
    "strict_failed_stop": "people_fail",
    "protocol_fail": "protocol_people_fail",
}


class CrowdError(BioVLNError):
    """A crowd that cannot be made: too many people for the scene's instrument faces."""


def step_seconds(forward_step: float, turn_deg: float) -> float:
    """The duration (s) of every action step: the longer of a FORWARD at :data:`ROBOT_SPEED` and a turn at
    :data:`ROBOT_TURN_RATE` (0.5 s for the benchmark's 0.25 m and 30 degrees). A STOP, a blocked move and a
    no-action step last as long: the people move meanwhile."""
    return max(forward_step / ROBOT_SPEED, turn_deg / ROBOT_TURN_RATE)


def people_config(cfg):
    """A :class:`~biovln_ms.task_config.NavTaskConfig` with people: its measures and the people's, and the
    fail measure that adds a person collision (when ``person_collision_ends``) to the variant's
    (:data:`PEOPLE_FAIL`; a variant's own fail measure is kept). Unchanged without people."""
    if not cfg.people:
        return cfg
    fail = PEOPLE_FAIL.get(cfg.fail_measure, cfg.fail_measure)
    return replace(cfg, measures=tuple(dict.fromkeys(cfg.measures + PEOPLE_MEASURES)), fail_measure=fail)


@dataclass(frozen=True)
class Stations:
    """The instrument faces people stand at: ids, Eq. 1 goal points and the people's yaw there."""

    ids: tuple[str, ...]
    stand: np.ndarray  # (S, 2)
    yaw: np.ndarray  # (S,) facing the face (along -f)


def stations(spec, nav: NavGeometry, start_xy) -> Stations:
    """The goal objects of scene ``spec`` whose Eq. 1 goal point is navigable on the robot start's island:
    every face a person can walk to from where the robot starts."""
    island = nav.island_of(np.asarray(start_xy, float))
    ids, stand, yaw = [], [], []
    for o in spec.goal_objects():
        if o.face is None or o.goal is None or nav.island_of(np.asarray(o.goal)) != island:
            continue
        ids.append(o.id)
        stand.append(o.goal)
        yaw.append(math.atan2(-o.face[1], -o.face[0]))
    return Stations(tuple(ids), np.asarray(stand, float).reshape(-1, 2), np.asarray(yaw, float))


class Crowd:
    """``n`` people of one sub-env (:meth:`reset` places them for an episode)."""

    #: the arrays of a crowd's state, each with a leading person dimension
    STATE = (
        "present",
        "pos",
        "yaw",
        "mode",
        "target",
        "timer",
        "waited",
        "visits",
        "speed",
        "route",
        "route_len",
        "leg",
    )

    def __init__(self, n: int) -> None:
        self.n = n
        self.present = np.ones(n, dtype=bool)  # in this episode (the first ``count`` of the slots)
        self.pos, self.yaw = np.zeros((n, 2)), np.zeros(n)
        self.mode, self.target = np.zeros(n, np.int64), np.zeros(n, np.int64)
        self.timer, self.waited, self.speed = np.zeros(n), np.zeros(n), np.zeros(n)
        self.visits = np.zeros(n, np.int64)
        self.route = np.zeros((n, ROUTE_POINTS, 2))
        self.route_len, self.leg = np.zeros(n, np.int64), np.zeros(n, np.int64)
        self.nav: NavGeometry | None = None
        self._paths: dict[tuple[float, ...], np.ndarray | None] = {}  # shortest paths, by their ends
        self.robot_radius, self.seed = 0.0, 0

    # --- an episode -------------------------------------------------------------------------------
    def reset(
        self,
        nav: NavGeometry,
        st: Stations,
        robot_xy,
        robot_radius: float,
        seed: int,
        scene="",
        count: int | None = None,
    ) -> None:
        """``count`` people (default: every slot; the others absent, at :data:`ABSENT_XY`) standing at faces
        apart from each other and from the robot's start, each for a part of a dwell time, drawn from
        ``seed``; a one-line CrowdError when the scene has too few such faces."""
        count = self.n if count is None else int(count)
        if not 0 <= count <= self.n:
            raise CrowdError(
                f"an episode with {count} people in a crowd of {self.n}",
                field="people",
                fix=f"pass people={count} or more",
            )
        if robot_radius < PERSON_RADIUS:
            raise CrowdError(
                f"people walk the robot's free space, and this robot's {robot_radius} m footprint is "
                f"smaller than a person's {PERSON_RADIUS} m",
                field="people",
                fix="use people=0 with this robot",
            )
        if nav is not self.nav:  # another scene's geometry
            self._paths = {}
        self.nav, self.st, self.robot_radius, self.seed = nav, st, float(robot_radius), int(seed)
        rng = np.random.default_rng([self.seed, PEOPLE_STREAM])
        self.speed[:] = 0.0  # the draws are the episode's people's only: any number of slots gives one crowd
        self.speed[:count] = rng.uniform(*SPEED_RANGE, count)
        robot = np.asarray(robot_xy, float)[:2]
        chosen: list[int] = []
        for s in rng.permutation(len(st.ids)).tolist():
            if len(chosen) == count:
                break
            far = np.hypot(*(st.stand[s] - robot)) >= PERSON_RADIUS + robot_radius + START_CLEARANCE
            if far and all(self._apart(s, c) for c in chosen):
                chosen.append(s)
        if len(chosen) < count:
            raise CrowdError(
                f"scene '{scene}' has {len(chosen)} instrument faces where people can stand apart from each "
                f"other and from the robot's start; people={count} needs {count}",
                field="people",
                fix=f"pass people={len(chosen)} or fewer, or use a scene with more instruments",
            )
        self.present[:] = np.arange(self.n) < count
        self.pos[:], self.yaw[:] = ABSENT_XY, 0.0
        self.pos[:count] = st.stand[chosen]
        self.yaw[:count] = st.yaw[chosen]
        self.target[:] = -1
        self.target[:count] = chosen
        self.mode[:] = STAND
        self.timer[:] = 0.0
        self.timer[:count] = rng.uniform(0.0, DWELL_RANGE[1], count)
        self.waited[:] = 0.0
        self.visits[:] = 0
        self.route_len[:] = 0
        self.leg[:] = 0

    def state(self) -> dict[str, np.ndarray]:
        """Copies of every state array."""
        return {k: getattr(self, k).copy() for k in self.STATE}

    def load(self, state: dict) -> None:
        """Restore :meth:`state` output (the same episode: its stations and seed are the reset's)."""
        for k in self.STATE:
            getattr(self, k)[...] = np.asarray(state[k])

    # --- the robot's move -------------------------------------------------------------------------
    def cut(self, x: float, y: float, tx: float, ty: float) -> tuple[float, float, bool]:
        """The robot's move from (x, y) toward (tx, ty) stopped 1 mm before its body first touches a
        person's, and whether it was (a person collision): the first root of |(x, y) + t d - p| = contact
        over the people p moving closer (on Python floats, as a tick's geometry)."""
        dx, dy = tx - x, ty - y
        length2 = dx * dx + dy * dy
        if length2 == 0.0:
            return tx, ty, False
        contact = PERSON_RADIUS + self.robot_radius
        first = math.inf
        for px, py in self.pos.tolist():
            fx, fy = x - px, y - py
            b = fx * dx + fy * dy
            if b >= 0.0:  # not moving closer
                continue
            c = fx * fx + fy * fy - contact * contact
            if c <= 0.0:  # already touching and moving closer
                first = 0.0
                continue
            disc = b * b - length2 * c
            if disc >= 0.0:
                first = min(first, (-b - math.sqrt(disc)) / length2)
        if first > 1.0:
            return tx, ty, False
        first = max(0.0, first - 1e-3 / math.sqrt(length2))
        return x + dx * first, y + dy * first, True

    # --- the people's moves -----------------------------------------------------------------------
    def advance(self, seconds: float, robot_xy) -> float:
        """Move the people for ``seconds`` with the robot at ``robot_xy``; the person-seconds they spent
        waiting for the robot."""
        robot = (float(robot_xy[0]), float(robot_xy[1]))
        ticks = max(1, round(seconds / TICK))
        dt, waited_for_robot = seconds / ticks, 0.0
        mode, timer = self.mode, self.timer
        moving = []  # people whose step needs ticks in turn: those standing on throughout depend on no one
        for p in (p for p, here in enumerate(self.present.tolist()) if here):
            if mode[p] == STAND:
                t, k = float(timer[p]), 0
                while k < ticks and t > dt:
                    t, k = t - dt, k + 1
                if k == ticks:
                    timer[p] = t
                    continue
            moving.append(p)
        for _ in range(ticks):
            for p in moving:
                if mode[p] == STAND and timer[p] > dt:  # standing on: _tick's work, faster
                    timer[p] -= dt
                else:
                    waited_for_robot += self._tick(p, dt, robot)
        return waited_for_robot

    def _tick(self, p: int, dt: float, robot: tuple[float, float]) -> float:
        """Person ``p``'s tick; the seconds it waited for the robot."""
        if self.mode[p] == STAND:
            self.timer[p] -= dt
            if self.timer[p] <= 0.0 and not self._retarget(p):
                self.timer[p] = DWELL_RANGE[0]  # no free face: stand a while longer
            return 0.0
        step = float(self.speed[p]) * dt
        at = self.pos.tolist()  # everyone's place before this move
        cand, leg = self._along(p, step, at[p])
        blocker = self._blocker(p, cand, robot, at)
        if blocker == 0:
            self._move(p, cand, leg, at[p])
            return 0.0
        side = self._sidestep(p, cand, step, robot, at)
        self.waited[p] += dt
        if side is not None:  # off the route: a new one from there
            x, y = at[p]
            self.yaw[p] = math.atan2(side[1] - y, side[0] - x)
            self.pos[p, 0], self.pos[p, 1] = side
            self._plan(p, int(self.target[p]))
        elif self.waited[p] >= PATIENCE:
            self._retarget(p)
        return dt if blocker == _ROBOT and side is None else 0.0

    # A tick's geometry is on Python floats: a crowd is a few people, and NumPy's per-call cost dominates.
    def _along(self, p: int, dist: float, at: list[float]) -> tuple[tuple[float, float], int]:
        """Where ``dist`` metres along person ``p``'s route from ``at`` (their place) end, and the index of
        the next waypoint."""
        (x, y), k, end = at, int(self.leg[p]), int(self.route_len[p])
        route = self.route[p]
        while dist > 0.0 and k < end:
            wx, wy = route[k].tolist()
            d = math.hypot(wx - x, wy - y)
            if d <= dist:
                x, y, dist, k = wx, wy, dist - d, k + 1
            else:
                f = dist / d
                x, y, dist = x + (wx - x) * f, y + (wy - y) * f, 0.0
        return (x, y), k

    def _blocker(
        self, p: int, cand: tuple[float, float], robot: tuple[float, float], at: list[list[float]]
    ) -> int:
        """What a move of person ``p`` to ``cand`` would come too close to (0: nothing): the robot's body or
        another person's, nearer than GAP and nearer than before (``at``: everyone's place now)."""
        (cx, cy), (ox, oy), (rx, ry) = cand, at[p], robot
        r = math.hypot(cx - rx, cy - ry)
        if r < PERSON_RADIUS + self.robot_radius + GAP and r <= math.hypot(ox - rx, oy - ry):
            return _ROBOT
        for q, (qx, qy) in enumerate(at):
            if q != p:  # not themselves
                near = math.hypot(qx - cx, qy - cy)
                if near < 2 * PERSON_RADIUS + GAP and near <= math.hypot(qx - ox, qy - oy):
                    return _PERSON
        return 0

    def _sidestep(
        self,
        p: int,
        cand: tuple[float, float],
        step: float,
        robot: tuple[float, float],
        at: list[list[float]],
    ) -> tuple[float, float] | None:
        """A step of length ``step`` off the way to ``cand`` (right, then left) inside the free space and
        clear of everyone (``at``: everyone's place now), or None."""
        x, y = at[p]
        dx, dy = cand[0] - x, cand[1] - y
        if not (dx or dy):
            return None
        heading = math.atan2(dy, dx)
        for turn in (-SIDESTEP_DEG, SIDESTEP_DEG):
            a = heading + math.radians(turn)
            side = (x + step * math.cos(a), y + step * math.sin(a))
            # the cheap test first: most sidesteps are blocked by the same person or robot
            if self._blocker(p, side, robot, at) == 0 and shapely.covers(
                self.nav.free, LineString([(x, y), side])
            ):
                return side
        return None

    def _move(self, p: int, to: tuple[float, float], leg: int, at: list[float]) -> None:
        x, y = at
        if to[0] - x or to[1] - y:
            self.yaw[p] = math.atan2(to[1] - y, to[0] - x)
        pos = self.pos
        pos[p, 0], pos[p, 1], self.leg[p] = to[0], to[1], leg  # scalars: cheaper than a row from a tuple
        if leg < self.route_len[p]:
            return
        s = int(self.target[p])
        if (self.pos[p] == self.st.stand[s]).all():  # arrived: stand at the face
            self.mode[p], self.yaw[p], self.waited[p] = STAND, self.st.yaw[s], 0.0
            rng = np.random.default_rng([self.seed, PEOPLE_STREAM, p + 1, int(self.visits[p]), 1])
            self.timer[p] = rng.uniform(*DWELL_RANGE)
        else:  # the end of a long route's kept part
            self._plan(p, s)

    def _apart(self, s: int, other: int) -> bool:
        """Whether people standing at faces ``s`` and ``other`` keep GAP between their bodies."""
        d = self.st.stand[s] - self.st.stand[other]
        return s != other and math.hypot(*d) >= 2 * PERSON_RADIUS + GAP

    def _retarget(self, p: int) -> bool:
        """Person ``p`` walks to another face no one else has claimed, in a stateless random order; whether
        one was found."""
        self.visits[p] += 1
        rng = np.random.default_rng([self.seed, PEOPLE_STREAM, p + 1, int(self.visits[p])])
        others = [int(self.target[q]) for q in range(self.n) if q != p and self.present[q]]
        for s in rng.permutation(len(self.st.ids)).tolist():
            if s != self.target[p] and all(self._apart(s, o) for o in others) and self._plan(p, s):
                self.target[p], self.mode[p], self.waited[p] = s, WALK, 0.0
                return True
        self.waited[p] = 0.0
        return False

    def _plan(self, p: int, s: int) -> bool:
        """Person ``p``'s route to face ``s`` (its first ROUTE_POINTS waypoints); whether there is one."""
        key = (*self.pos[p].tolist(), *self.st.stand[s].tolist())
        if key not in self._paths:  # people walk between the same faces again and again
            if len(self._paths) >= MAX_CACHED_PATHS:  # routes from where a sidestep left someone: unbounded
                self._paths.clear()
            try:
                self._paths[key] = self.nav.shortest_path(self.pos[p], self.st.stand[s])[1:][:ROUTE_POINTS]
            except UnreachableError:
                self._paths[key] = None
        path = self._paths[key]
        if path is None:
            return False
        self.route[p, : len(path)] = path
        self.route_len[p], self.leg[p] = len(path), 0
        return True
