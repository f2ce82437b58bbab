"""The three-zone operational envelope of an instrument (paper §3.2, Eq. 1-4).

Zone 1 is the oriented footprint of the body, Zone 2 that footprint grown by the safety clearance
epsilon_c on all four sides, Zone 3 the rectangle of depth delta in front of the operational face.
epsilon_c is the catalog's ``zone2_clearance``: an instrument takes it from the catalog its
dimensions came from (``PlacedInstrument.from_asset``), the packaged catalog otherwise.
Everything here is planar geometry in world coordinates, Z up, metres, yaw in radians (CCW).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field

import numpy as np
from shapely.geometry import Polygon

from biovln_ms.catalog import AssetSpec, load_catalog

#: Clearance below which a position counts as unsafe for MCR/VRT and the reward (paper §4.2, Eq. 5).
#: The paper prints it as a fixed 0.5 m (the gap Eq. 2 guarantees with its epsilon_c = 0.25 m); it is an
#: evaluation constant, kept apart from a catalog's clearance so that metrics stay comparable.
SAFETY_THRESHOLD = 0.5


def default_zone2_clearance() -> float:
    """epsilon_c of Eq. 2 in the packaged catalog (loaded once, cached)."""
    return load_catalog().zone2_clearance


def rot2(yaw: float) -> np.ndarray:
    """2x2 rotation matrix for a CCW yaw."""
    c, s = math.cos(yaw), math.sin(yaw)
    return np.array([[c, -s], [s, c]])


def wrap_angle(a: float) -> float:
    """Wrap an angle to (-pi, pi]."""
    a = math.fmod(a + math.pi, 2 * math.pi)
    if a <= 0:
        a += 2 * math.pi
    return a - math.pi


def yaw_facing(model_face: Sequence[float], interior: Sequence[float]) -> float:
    """Eq. 3: the Z rotation turning model-space face (m_x, m_y) onto the wall's interior (w_x, w_y)."""
    mx, my = model_face
    wx, wy = interior
    return math.atan2(mx * wy - my * wx, mx * wx + my * wy)


def placement_z(support_top: float, bb_center_z: float, bottom_z: float) -> float:
    """Eq. 4: Z of the model origin so that its lowest vertex rests on the support surface."""
    return support_top + bb_center_z - bottom_z


def goal_position(
    center_xy: Sequence[float], face: Sequence[float], d_half: float, approach_distance: float
) -> np.ndarray:
    """Eq. 1: g = c + f (d + delta), on the floor plane."""
    return np.asarray(center_xy, float)[:2] + np.asarray(face, float) * (d_half + approach_distance)


@dataclass(frozen=True)
class PlacedInstrument:
    """An instrument placed in the world: its body box, operational face and Eq. 1 parameters."""

    center: tuple[float, float, float]
    yaw: float
    size: tuple[float, float, float]
    model_face: tuple[float, float] | None
    d_half: float = 0.0
    approach_distance: float = 0.0
    name: str = ""
    category: str = ""
    eps_c: float = field(default_factory=default_zone2_clearance)
    _rot: np.ndarray = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "_rot", rot2(self.yaw))

    @classmethod
    def from_asset(
        cls, asset: AssetSpec, center: Sequence[float], yaw: float, name: str = ""
    ) -> PlacedInstrument:
        """The asset placed at ``center`` and ``yaw``, with the epsilon_c (Eq. 2) of the catalog it came
        from."""
        face = asset.face_vector
        return cls(
            center=tuple(float(v) for v in center),
            yaw=float(yaw),
            size=tuple(asset.dimensions),
            model_face=None if face is None else (float(face[0]), float(face[1])),
            d_half=asset.d_half or 0.0,
            approach_distance=asset.approach_distance or 0.0,
            name=name or asset.name,
            category=asset.name,
            eps_c=asset.zone2_clearance,
        )

    # --- frames -------------------------------------------------------------------------------
    @property
    def center_xy(self) -> np.ndarray:
        return np.array(self.center[:2], float)

    @property
    def half_xy(self) -> np.ndarray:
        return np.array(self.size[:2], float) / 2.0

    @property
    def z_range(self) -> tuple[float, float]:
        return self.center[2] - self.size[2] / 2.0, self.center[2] + self.size[2] / 2.0

    @property
    def face(self) -> np.ndarray | None:
        """World-space unit normal of the operational face, f = R(yaw) m."""
        return None if self.model_face is None else self._rot @ np.array(self.model_face)

    @property
    def face_width(self) -> float:
        if self.model_face is None:
            return 0.0
        return self.size[1] if abs(self.model_face[0]) > 0.5 else self.size[0]

    def _rect(self, half: np.ndarray, center_local: np.ndarray | None = None) -> np.ndarray:
        """World corners (4, 2) of a rectangle given in the instrument's local frame."""
        c = np.zeros(2) if center_local is None else center_local
        local = np.array([[-1, -1], [1, -1], [1, 1], [-1, 1]], float) * half + c
        return local @ self._rot.T + self.center_xy

    # --- zones --------------------------------------------------------------------------------
    def zone1_corners(self) -> np.ndarray:
        return self._rect(self.half_xy)

    def zone2_corners(self) -> np.ndarray:
        """Zone 1 grown by epsilon_c on all four sides (Eq. 2)."""
        return self._rect(self.half_xy + self.eps_c)

    def zone3_corners(self) -> np.ndarray:
        """Rectangle of depth delta outward from the face, as wide as the face."""
        if self.model_face is None:
            raise ValueError(f"instrument '{self.name}' has no operational face, so no Zone 3")
        m = np.array(self.model_face)
        depth_axis = 0 if abs(m[0]) > 0.5 else 1
        half = np.empty(2)
        half[depth_axis] = self.approach_distance / 2.0
        half[1 - depth_axis] = self.face_width / 2.0
        center_local = m * (self.d_half + self.approach_distance / 2.0)
        return self._rect(half, center_local)

    def zone1(self) -> Polygon:
        return Polygon(self.zone1_corners())

    def zone2(self) -> Polygon:
        return Polygon(self.zone2_corners())

    def zone3(self) -> Polygon:
        return Polygon(self.zone3_corners())

    def goal(self) -> np.ndarray:
        """Eq. 1 operational-face goal on the floor."""
        if self.face is None:
            raise ValueError(f"instrument '{self.name}' has no operational face, so no goal")
        return goal_position(self.center_xy, self.face, self.d_half, self.approach_distance)

    def centroid_goal(self) -> np.ndarray:
        """Floor projection of the bounding-box centre (the ObjectNav-style goal of Table 9)."""
        return self.center_xy.copy()

    # --- clearance ----------------------------------------------------------------------------
    def clearance(self, points: np.ndarray, z: float | Sequence[float] | None = None) -> np.ndarray:
        """Distance from points to the body surface (0 inside).

        ``points`` is (2,) or (N, 2). With ``z`` None the distance is planar (to the footprint);
        with a height z, or a vertical interval (z0, z1), it is the 3D distance to the body box.
        """
        p = np.atleast_2d(np.asarray(points, float))
        local = (p - self.center_xy) @ self._rot
        d = np.maximum(np.abs(local) - self.half_xy, 0.0)
        dist_sq = (d**2).sum(axis=1)
        if z is not None:
            z0, z1 = (z, z) if np.isscalar(z) else (float(z[0]), float(z[1]))
            bz0, bz1 = self.z_range
            gap = max(0.0, bz0 - z1, z0 - bz1)
            dist_sq = dist_sq + gap * gap
        out = np.sqrt(dist_sq)
        return out if np.ndim(points) > 1 else out[0]


def _sat_disjoint(a: np.ndarray, b: np.ndarray, tol: float = 1e-9) -> bool:
    """Separating-axis test for two convex quadrilaterals; touching counts as disjoint."""
    for poly in (a, b):
        for i in range(4):
            edge = poly[(i + 1) % 4] - poly[i]
            axis = np.array([-edge[1], edge[0]])
            pa, pb = a @ axis, b @ axis
            if pa.max() <= pb.min() + tol * np.linalg.norm(
                axis
            ) or pb.max() <= pa.min() + tol * np.linalg.norm(axis):
                return True
    return False


def zone2_disjoint(a: PlacedInstrument, b: PlacedInstrument) -> bool:
    """Eq. 2 generalised to any yaw: the two Zone-2 rectangles do not overlap (touching allowed).

    For axis-aligned instruments this is exactly Eq. 2 (see ``eq2_axis_aligned``).
    """
    return _sat_disjoint(a.zone2_corners(), b.zone2_corners())


def world_extent(inst: PlacedInstrument) -> np.ndarray:
    """World-axis extents (s_x, s_y) of the rotated footprint."""
    return np.abs(rot2(inst.yaw)) @ np.array(inst.size[:2], float)


def eq2_axis_aligned(a: PlacedInstrument, b: PlacedInstrument) -> bool:
    """Eq. 2 as printed: |x_i - x_j| >= (s_x,i + s_x,j)/2 + 2 eps_c or the same in y.

    2 eps_c is the sum of the two instruments' own clearances (equal when they share a catalog).
    """
    sa, sb = world_extent(a), world_extent(b)
    dx, dy = np.abs(a.center_xy - b.center_xy)
    two_eps = a.eps_c + b.eps_c
    return bool(dx >= (sa[0] + sb[0]) / 2 + two_eps - 1e-9 or dy >= (sa[1] + sb[1]) / 2 + two_eps - 1e-9)


def min_clearance(
    points: np.ndarray, instruments: Iterable[PlacedInstrument], z: float | Sequence[float] | None = None
) -> np.ndarray:
    """Per point, the clearance to the nearest instrument body (inf when there are none)."""
    p = np.atleast_2d(np.asarray(points, float))
    out = np.full(len(p), np.inf)
    for inst in instruments:
        out = np.minimum(out, inst.clearance(p, z))
    return out


class InstrumentArray:
    """Many instruments stacked for vectorised per-point queries (the per-step measures' hot path)."""

    def __init__(self, instruments: Sequence[PlacedInstrument]) -> None:
        self.n = len(instruments)
        self.centers = np.array([i.center_xy for i in instruments]).reshape(-1, 2)
        yaw = np.array([i.yaw for i in instruments])
        self.cos, self.sin = np.cos(yaw), np.sin(yaw)
        self.half = np.array([i.half_xy for i in instruments]).reshape(-1, 2)
        self.eps = np.array([i.eps_c for i in instruments])
        self._last: tuple[float, float, np.ndarray] | None = None

    def _local(self, p: np.ndarray) -> np.ndarray:
        """|p| in each instrument's frame, (n, 2); the last point's is kept (clearance and Zone 2 ask in
        turn for the same point)."""
        x, y = float(p[0]), float(p[1])
        if self._last is not None and self._last[0] == x and self._last[1] == y:
            return self._last[2]
        d = np.array([x, y]) - self.centers
        out = np.empty_like(d)
        out[:, 0] = np.abs(self.cos * d[:, 0] + self.sin * d[:, 1])
        out[:, 1] = np.abs(-self.sin * d[:, 0] + self.cos * d[:, 1])
        self._last = (x, y, out)
        return out

    def clearance(self, p) -> float:
        """Planar distance from p to the nearest body (inf when there are none)."""
        if self.n == 0:
            return math.inf
        gap = np.maximum(self._local(p) - self.half, 0.0)
        return float(np.sqrt((gap**2).sum(axis=1)).min())

    def in_zone2(self, p) -> bool:
        """Whether p lies inside any instrument's Zone 2 (the body rectangle grown by eps_c)."""
        if self.n == 0:
            return False
        return bool(np.any(np.all(self._local(p) <= self.half + self.eps[:, None], axis=1)))
