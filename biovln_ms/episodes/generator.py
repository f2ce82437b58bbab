"""Episode construction (paper §3.3 "Episode Construction").

No episode is trivial (our rule; the paper is silent): a start lies outside its goal's success radius r
(Euclidean distance > r) and at least r + ``MIN_START_GEODESIC_MARGIN`` (1.0 m) from the goal along the
floor (``keeps_start_rule``). Starts are sampled uniformly over the navigable area at least
``min_start_clearance`` (1.0 m) from every obstacle (instrument and furniture bodies, walls) where the
rule holds; draws that break it are rejected and redrawn from the same generator. When a scene has no
such area for a goal, the documented fallback takes the band of largest clearance where the rule holds
and records that clearance on the episode.
Goals are the Eq. 1 operational-face goals snapped to navigable floor, with view points (navigable
poses inside Zone 3 and the success radius, turned toward the instrument). Difficulty tiers follow
the geodesic distance: easy < 3.0 m, medium 3.0-6.0 m, hard > 6.0 m.

The Hard track (``any_instance_episodes``) asks for a category, not an instance, as ObjectNav does: every
instance of the category in the scene is a goal and reaching any counts. The rule then holds for the
nearest instance (outside every instance's radius, >= r + 1.0 m along the floor from the nearest), and a
share of the episodes is drawn for a geodesic distance over 6 m (hard): up to ``MAX_HARD_ATTEMPTS``
starts, else the longest valid one (the episode then records its true tier).
"""

from __future__ import annotations

import math
import zlib

import numpy as np
import shapely
from shapely.geometry import Polygon
from shapely.geometry.base import BaseGeometry
from shapely.ops import unary_union

from biovln_ms.episodes.schema import Episode, Goal
from biovln_ms.errors import BioVLNError
from biovln_ms.geometry.freespace import grow
from biovln_ms.geometry.navigation import NavGeometry
from biovln_ms.scene.rules import scene_navigation
from biovln_ms.scene.rules import floor_polygon
from biovln_ms.scene.spec import ObjectSpec, SceneSpec

MIN_START_CLEARANCE = 1.0
MIN_START_GEODESIC_MARGIN = 1.0  # a start's geodesic distance to its goal is >= success radius + this
MIN_KEEP_SHARE = 0.1  # share of a start region that must keep the rule for plain rejection sampling
MAX_START_ATTEMPTS = 1000  # starts drawn per episode before a scene is declared unable to satisfy it
RASTER = 0.05  # m, cell of the clearance raster of start regions
VIEW_POINT_SPACING = 0.15
MAX_VIEW_POINTS = 12
HARD_GEODESIC = 6.0  # m: the appendix's hard tier starts here
MAX_HARD_ATTEMPTS = 200  # starts drawn for a hard episode before the longest valid one is taken


class EpisodeError(BioVLNError):
    """A scene cannot give valid episodes (e.g. an instrument's Zone 3 is unreachable)."""


def difficulty(geodesic: float) -> str:
    """Tier of the paper's appendix: easy < 3.0 m <= medium <= 6.0 m < hard."""
    return "easy" if geodesic < 3.0 else ("medium" if geodesic <= 6.0 else "hard")


def keeps_start_rule(geodesic: float, euclidean: float, radius: float) -> bool:
    """No trivial episode: the start lies outside the success radius ``radius`` of its goal and at least
    ``radius + MIN_START_GEODESIC_MARGIN`` from it along the floor (and can reach it)."""
    return euclidean > radius and radius + MIN_START_GEODESIC_MARGIN <= geodesic < math.inf


def yaw_to_quat(yaw: float) -> list[float]:
    """wxyz quaternion (SAPIEN/ManiSkill convention) of a yaw about Z."""
    return [math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2)]


def stable_seed(*parts: object) -> int:
    return zlib.crc32("/".join(map(str, parts)).encode())


def _r6(v):
    return [round(float(x), 6) for x in v]


class EpisodeSampler:
    """Samples episodes in one scene; all randomness from ``numpy.random.default_rng(seed)``."""

    def __init__(
        self,
        spec: SceneSpec,
        nav: NavGeometry | None = None,
        min_start_clearance: float = MIN_START_CLEARANCE,
    ):
        self.spec = spec
        self.nav = nav or scene_navigation(spec)
        self.min_start_clearance = min_start_clearance
        goals = {o.id: self.nav.island_of(self.nav.snap(o.goal)) for o in spec.goal_objects()}
        self.island = next(iter(goals.values()))
        obstacles = [o.placed().zone1() for o in spec.objects()]
        self._floor = floor_polygon(spec)
        self._obstacles = unary_union(obstacles)
        self._targets = {o.id: self._target(o) for o in spec.goal_objects()}
        self._start_floors: dict[tuple[str, ...] | None, tuple[Polygon, BaseGeometry]] = {}
        self._rasters: dict[tuple[str, ...] | None, np.ndarray] = {}
        self._start_regions: dict[tuple[tuple[str, ...] | None, str], tuple[Polygon, float]] = {}
        bad = [k for k, v in goals.items() if v != self.island]
        if bad:
            raise EpisodeError(
                f"scene '{spec.name}': goals of {bad} are not on the island of the other goals",
                fix="regenerate the scene (the generator guarantees mutually reachable goals)",
            )

    # --- goals ----------------------------------------------------------------------------------
    def _target(self, o: ObjectSpec) -> Goal:
        nav = self.nav
        isl_poly = nav.islands[self.island]
        z3 = o.placed().zone3()
        reach = z3.intersection(isl_poly)
        if reach.is_empty or reach.area < 1e-6:
            raise EpisodeError(
                f"scene '{self.spec.name}': Zone 3 of '{o.id}' ({o.category}) has no navigable floor for a "
                f"{nav.radius} m robot, so its goal cannot be reached",
                field=o.id,
                fix="move the instrument or shrink the robot radius",
            )
        goal = nav.snap(o.goal, self.island)
        if np.linalg.norm(goal - np.asarray(o.goal)) > o.success_radius:
            raise EpisodeError(
                f"scene '{self.spec.name}': the navigable point nearest the goal of '{o.id}' is "
                f"{np.linalg.norm(goal - np.asarray(o.goal)):.2f} m away, beyond its success radius",
                field=o.id,
            )
        c = np.asarray(o.position[:2])
        # View points: a grid over Zone 3 within the success radius, navigable, facing the instrument.
        minx, miny, maxx, maxy = z3.bounds
        xs = np.arange(minx + VIEW_POINT_SPACING / 2, maxx, VIEW_POINT_SPACING)
        ys = np.arange(miny + VIEW_POINT_SPACING / 2, maxy, VIEW_POINT_SPACING)
        gx, gy = (a.ravel() for a in np.meshgrid(xs, ys))
        ok = shapely.contains_xy(reach, gx, gy)
        ok &= np.hypot(gx - o.goal[0], gy - o.goal[1]) <= o.success_radius
        pts = np.stack([gx[ok], gy[ok]], axis=1)
        pts = pts[np.argsort(np.linalg.norm(pts - goal, axis=1), kind="stable")][: MAX_VIEW_POINTS - 1]
        view = [goal, *pts]
        view_points = [
            {
                "agent_state": {
                    "position": _r6([p[0], p[1], 0.0]),
                    "rotation": _r6(yaw_to_quat(math.atan2(c[1] - p[1], c[0] - p[0]))),
                }
            }
            for p in view
        ]
        return {
            "position": _r6([goal[0], goal[1], 0.0]),
            "radius": o.success_radius,
            "object_id": o.id,
            "object_category": o.category,
            "eq1_goal": _r6(o.goal),
            "view_points": view_points,
        }

    # --- starts ---------------------------------------------------------------------------------
    def _floor_for_starts(self, rooms: tuple[str, ...] | None) -> tuple[Polygon, BaseGeometry]:
        """Navigable floor of ``rooms`` (all: None) and what blocks it (cached)."""
        if rooms not in self._start_floors:
            isl = self.nav.islands[self.island]
            allowed = (
                isl
                if rooms is None
                else isl.intersection(
                    unary_union([Polygon(r.polygon) for r in self.spec.rooms if r.id in rooms])
                )
            )
            outside = self._floor.envelope.buffer(2.0).difference(self._floor)
            self._start_floors[rooms] = allowed, unary_union([outside, self._obstacles])
        return self._start_floors[rooms]

    def _raster(self, rooms: tuple[str, ...] | None) -> np.ndarray:
        """Centres of the ``RASTER`` cells of the floor of ``rooms`` and their clearance (x, y, clearance),
        cached."""
        if rooms not in self._rasters:
            allowed, blocked = self._floor_for_starts(rooms)
            minx, miny, maxx, maxy = allowed.bounds
            xs = np.arange(minx, maxx, RASTER) + RASTER / 2
            ys = np.arange(miny, maxy, RASTER) + RASTER / 2
            gx, gy = (a.ravel() for a in np.meshgrid(xs, ys))
            ok = shapely.contains_xy(allowed, gx, gy)
            d = shapely.distance(blocked, shapely.points(gx[ok], gy[ok]))
            self._rasters[rooms] = np.stack([gx[ok], gy[ok], d], axis=1)
        return self._rasters[rooms]

    def start_region(self, target: Goal, rooms: tuple[str, ...] | None = None) -> tuple[Polygon, float]:
        """Where starts to ``target`` are drawn, and the clearance from obstacles they keep (cached).

        The floor at least ``min_start_clearance`` from obstacles, outside the success radius; when less
        than ``MIN_KEEP_SHARE`` of it is r + margin away in a straight line (where the rule surely holds),
        only its ``RASTER`` cells whose centre keeps the rule, or, if none does (fallback), those of the
        band of largest clearance where one does. ``_start`` still checks every draw."""
        key = (rooms, target["object_id"])
        if key in self._start_regions:
            return self._start_regions[key]
        allowed, blocked = self._floor_for_starts(rooms)
        goal, r = np.asarray(target["position"][:2]), target["radius"]
        far_r = r + MIN_START_GEODESIC_MARGIN
        region = allowed.difference(grow(blocked, self.min_start_clearance))
        region = region.difference(shapely.Point(goal).buffer(r))
        far = region.difference(shapely.Point(goal).buffer(far_r)).area  # geodesic >= Euclidean
        clearance: float | None = self.min_start_clearance
        if far <= 1e-4 or far < MIN_KEEP_SHARE * region.area:
            cells = self._raster(rooms)
            geodesic = self.nav.distance_to(goal)
            euclidean = np.linalg.norm(cells[:, :2] - goal, axis=1)
            keep = np.zeros(len(cells), bool)
            top, clearance = self.min_start_clearance + RASTER, None
            for i in np.argsort(-cells[:, 2], kind="stable"):  # down to the band of the first keeper
                if clearance is not None and cells[i, 2] < clearance:
                    break
                keep[i] = euclidean[i] >= far_r or keeps_start_rule(geodesic(cells[i, :2]), euclidean[i], r)
                if keep[i] and clearance is None:
                    clearance = self.min_start_clearance if cells[i, 2] >= top else cells[i, 2] - RASTER
            if clearance is None:
                where = "" if rooms is None else f" in rooms {list(rooms)}"
                raise EpisodeError(
                    f"scene '{self.spec.name}': no navigable floor{where} is at least {far_r:.2f} m "
                    f"(success radius + {MIN_START_GEODESIC_MARGIN} m) along the floor from the goal of "
                    f"'{target['object_id']}' ({target['object_category']})",
                    field=target["object_id"],
                    fix="give the scene more free floor away from this instrument, or move the instrument",
                )
            low, high = (cells[keep, :2] - RASTER / 2).T, (cells[keep, :2] + RASTER / 2).T
            region = allowed.difference(grow(blocked, clearance))
            region = region.intersection(unary_union(shapely.box(*low, *high)))
        self._start_regions[key] = region, float(clearance)
        return self._start_regions[key]

    @staticmethod
    def sample_in(region, rng: np.random.Generator) -> np.ndarray:
        minx, miny, maxx, maxy = region.bounds
        shapely.prepare(region)
        for _ in range(1000):
            x = rng.uniform(minx, maxx, 64)
            y = rng.uniform(miny, maxy, 64)
            inside = np.flatnonzero(shapely.contains_xy(region, x, y))
            if len(inside):
                return np.array([x[inside[0]], y[inside[0]]])
        raise EpisodeError("could not sample a start in a non-empty region (degenerate geometry)")

    def _start(self, region: Polygon, target: Goal, rng: np.random.Generator) -> tuple[np.ndarray, float]:
        """A start in ``region`` that keeps the rule for ``target`` (rejection sampling), and its geodesic
        distance to the goal."""
        goal, r, oid = np.asarray(target["position"][:2]), target["radius"], target["object_id"]
        for _ in range(MAX_START_ATTEMPTS):
            start = np.round(self.sample_in(region, rng), 6)  # as stored, so the stored start keeps the rule
            geo = self.nav.geodesic_distance(start, goal)
            if not np.isfinite(geo):
                raise EpisodeError(f"scene '{self.spec.name}': start {start.tolist()} cannot reach '{oid}'")
            if keeps_start_rule(geo, float(np.linalg.norm(goal - start)), r):
                return start, geo
        raise EpisodeError(
            f"scene '{self.spec.name}': none of {MAX_START_ATTEMPTS} starts drawn is at least "
            f"{r + MIN_START_GEODESIC_MARGIN:.2f} m along the floor from the goal of '{oid}' "
            f"({target['object_category']}) and outside its success radius",
            field=oid,
            fix="give the scene more free floor away from this instrument, or move the instrument",
        )

    def _any_instance_start(
        self, region: Polygon, targets: list[Goal], hard: bool, rng: np.random.Generator
    ) -> tuple[np.ndarray, np.ndarray]:
        """A start in ``region`` that keeps the rule for the nearest of ``targets`` and lies outside every
        target's radius; for a ``hard`` episode the first such start over ``HARD_GEODESIC`` from the
        nearest, else the longest of ``MAX_HARD_ATTEMPTS``. Returns the start and the geodesic to each."""
        goals = np.array([t["position"][:2] for t in targets])
        radii = np.array([t["radius"] for t in targets])
        best: tuple[np.ndarray, np.ndarray] | None = None
        for _ in range(MAX_HARD_ATTEMPTS if hard else MAX_START_ATTEMPTS):
            start = np.round(self.sample_in(region, rng), 6)
            euclidean = np.linalg.norm(goals - start, axis=1)
            if np.any(euclidean <= radii):
                continue
            geo = np.array([self.nav.geodesic_distance(start, g) for g in goals])
            k = int(np.argmin(geo))
            if not keeps_start_rule(geo[k], euclidean[k], radii[k]):
                continue
            if not hard or geo[k] > HARD_GEODESIC:
                return start, geo
            if best is None or geo[k] > best[1].min():
                best = start, geo
        if best is not None:
            return best
        cat = targets[0]["object_category"]
        raise EpisodeError(
            f"scene '{self.spec.name}': no start drawn keeps the rule for the nearest {cat}",
            field=cat,
            fix="give the scene more free floor away from its instruments",
        )

    def any_instance_episodes(
        self, n: int, seed: int, hard_share: float = 0.5, id_offset: int = 0
    ) -> list[Episode]:
        """``n`` Hard-track episodes cycling over the scene's goal categories (shuffled): every instance
        of the category is a goal, nearest first; episode k is drawn hard when floor((k + 1) h) >
        floor(k h), h = ``hard_share``."""
        rng = np.random.default_rng([stable_seed(self.spec.name), seed, 1])
        by_category: dict[str, list[Goal]] = {}
        for o in self.spec.goal_objects():
            by_category.setdefault(o.category, []).append(self._targets[o.id])
        categories = sorted(by_category)
        order = [categories[i] for i in rng.permutation(len(categories))]
        allowed, blocked = self._floor_for_starts(None)
        region = allowed.difference(grow(blocked, self.min_start_clearance))
        out = []
        for k in range(n):
            category = order[k % len(order)]
            hard = math.floor((k + 1) * hard_share) > math.floor(k * hard_share)
            start, geo = self._any_instance_start(region, by_category[category], hard, rng)
            yaw = float(rng.uniform(-math.pi, math.pi))
            goals = [by_category[category][i] for i in np.argsort(geo, kind="stable")]
            nearest = float(geo.min())
            euc = float(np.linalg.norm(np.asarray(goals[0]["position"][:2]) - start))
            out.append(
                {
                    "episode_id": str(id_offset + k),
                    "scene_id": self.spec.name,
                    "start_position": _r6([start[0], start[1], 0.0]),
                    "start_rotation": _r6(yaw_to_quat(yaw)),
                    "object_category": category,
                    "object_id": goals[0]["object_id"],
                    "goals": goals,
                    "info": {
                        "geodesic_distance": round(nearest, 6),
                        "euclidean_distance": round(euc, 6),
                        "difficulty": difficulty(nearest),
                        "start_clearance": round(self.min_start_clearance, 6),
                        "start_clearance_fallback": False,
                        "cross_room": False,
                        "any_instance": True,
                        "instances": len(goals),
                        "drawn_hard": hard,
                    },
                }
            )
        return out

    # --- episodes -------------------------------------------------------------------------------
    def episodes(self, n: int, seed: int, cross_room: bool = False, id_offset: int = 0) -> list[Episode]:
        """``n`` episodes cycling over the goal objects (shuffled); ``cross_room`` starts them in another
        room."""
        rng = np.random.default_rng([stable_seed(self.spec.name), seed])
        objs = self.spec.goal_objects()
        order = [objs[i] for i in rng.permutation(len(objs))]
        out = []
        for k in range(n):
            o = order[k % len(order)]
            rooms = None
            if cross_room:
                rooms = tuple(r.id for r in self.spec.rooms if r.kind == "room" and r.id != o.room)
                if not rooms:
                    raise EpisodeError(f"scene '{self.spec.name}' has one room: no cross-room episodes")
            target = self._targets[o.id]
            region, clearance = self.start_region(target, rooms)
            goal = np.asarray(target["position"][:2])
            start, geo = self._start(region, target, rng)
            yaw = float(rng.uniform(-math.pi, math.pi))
            euc = float(np.linalg.norm(goal - start))
            out.append(
                {
                    "episode_id": str(id_offset + k),
                    "scene_id": self.spec.name,
                    "start_position": _r6([start[0], start[1], 0.0]),
                    "start_rotation": _r6(yaw_to_quat(yaw)),
                    "object_category": o.category,
                    "object_id": o.id,
                    "goals": [target],
                    "info": {
                        "geodesic_distance": round(geo, 6),
                        "euclidean_distance": round(euc, 6),
                        "difficulty": difficulty(geo),
                        "start_clearance": round(clearance, 6),
                        "start_clearance_fallback": clearance < self.min_start_clearance,
                        "cross_room": cross_room,
                    },
                }
            )
        return out
