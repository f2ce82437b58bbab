"""Episode construction (paper §3.3 "Episode Construction").

Starts are sampled uniformly over the navigable area at least ``min_start_clearance`` (1.0 m) from
every obstacle (instrument and furniture bodies, walls). When a scene has no such area the documented
fallback takes the band of largest clearance available and records that clearance on the episode.
Goals are the Eq. 1 operational-face goals snapped to navigable floor, with view points (navigable
poses inside Zone 3 and the success radius, turned toward the instrument). Difficulty tiers follow
the geodesic distance: easy < 3.0 m, medium 3.0-6.0 m, hard > 6.0 m.
"""

from __future__ import annotations

import math
import zlib
from typing import Sequence

import numpy as np
import shapely
from shapely.geometry import Polygon
from shapely.ops import unary_union

from biovln_ms.errors import BioVLNError
from biovln_ms.geometry.freespace import grow
from biovln_ms.geometry.navigation import NavGeometry
from biovln_ms.scene.rules import scene_navigation
from biovln_ms.scene.rules import floor_polygon
from biovln_ms.scene.spec import ObjectSpec, SceneSpec

MIN_START_CLEARANCE = 1.0
VIEW_POINT_SPACING = 0.15
MAX_VIEW_POINTS = 12


class EpisodeError(BioVLNError):
    """A scene cannot give valid episodes (e.g. an instrument's Zone 3 is unreachable)."""


def difficulty(geodesic: float) -> str:
    """Tier of the paper's appendix: easy < 3.0 m <= medium <= 6.0 m < hard."""
    return "easy" if geodesic < 3.0 else ("medium" if geodesic <= 6.0 else "hard")


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
        bad = [k for k, v in goals.items() if v != self.island]
        if bad:
            raise EpisodeError(
                f"scene '{spec.name}': goals of {bad} are not on the island of the other goals",
                fix="regenerate the scene (the generator guarantees mutually reachable goals)",
            )

    # --- goals ----------------------------------------------------------------------------------
    def _target(self, o: ObjectSpec) -> dict:
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
    def start_region(self, rooms: Sequence[str] | None = None) -> tuple[Polygon, float]:
        """Region for starts and the clearance it guarantees (fallback: the best available)."""
        isl = self.nav.islands[self.island]
        allowed = (
            isl
            if rooms is None
            else isl.intersection(unary_union([Polygon(r.polygon) for r in self.spec.rooms if r.id in rooms]))
        )
        outside = self._floor.envelope.buffer(2.0).difference(self._floor)
        blocked = unary_union([outside, self._obstacles])
        region = allowed.difference(grow(blocked, self.min_start_clearance))
        if region.area > 1e-4:
            return region, self.min_start_clearance
        # Fallback: the clearance field on a 5 cm raster, keep the top band.
        minx, miny, maxx, maxy = allowed.bounds
        xs = np.arange(minx, maxx, 0.05) + 0.025
        ys = np.arange(miny, maxy, 0.05) + 0.025
        gx, gy = (a.ravel() for a in np.meshgrid(xs, ys))
        ok = shapely.contains_xy(allowed, gx, gy)
        if not ok.any():
            raise EpisodeError(f"scene '{self.spec.name}': no navigable floor for starts in rooms {rooms}")
        d = shapely.distance(blocked, shapely.points(gx[ok], gy[ok]))
        best = float(d.max()) - 0.05
        region = allowed.difference(grow(blocked, best))
        return region, best

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

    # --- episodes -------------------------------------------------------------------------------
    def episodes(self, n: int, seed: int, cross_room: bool = False, id_offset: int = 0) -> list[dict]:
        """``n`` episodes cycling over the goal objects (shuffled); ``cross_room`` starts them in another
        room."""
        rng = np.random.default_rng([stable_seed(self.spec.name), seed])
        objs = self.spec.goal_objects()
        order = [objs[i] for i in rng.permutation(len(objs))]
        regions: dict = {}
        out = []
        for k in range(n):
            o = order[k % len(order)]
            rooms = None
            if cross_room:
                rooms = tuple(r.id for r in self.spec.rooms if r.kind == "room" and r.id != o.room)
                if not rooms:
                    raise EpisodeError(f"scene '{self.spec.name}' has one room: no cross-room episodes")
            if rooms not in regions:
                regions[rooms] = self.start_region(rooms)
            region, clearance = regions[rooms]
            start = self.sample_in(region, rng)
            yaw = float(rng.uniform(-math.pi, math.pi))
            target = self._targets[o.id]
            goal = np.asarray(target["position"][:2])
            geo = self.nav.geodesic_distance(start, goal)
            if not np.isfinite(geo):
                raise EpisodeError(
                    f"scene '{self.spec.name}': start {start.round(3).tolist()} cannot reach '{o.id}'"
                )
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
