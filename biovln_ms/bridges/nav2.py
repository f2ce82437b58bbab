"""Nav2 bridge: a scene spec as the files a ROS 2 Nav2 stack loads (``biovln-ms export nav2``).

Frames: the scene's world frame is Nav2's ``map`` frame (x, y on the floor, z up, yaw CCW about z,
metres). A pixel (row, col) covers x in [ox + col res, ox + (col + 1) res) and
y in [oy + (H - 1 - row) res, oy + (H - row) res): row 0 is the top (largest y), as map_server reads
images, and ``origin`` [ox, oy, 0] is the lower-left corner of the lower-left pixel.

- ``map.pgm`` / ``map.yaml``: trinary map_server map of the static scene, raw occupancy (not inflated:
  set ``robot_radius`` in the costmaps and let the inflation layer grow it). A pixel is classified by its
  centre: occupied (0) inside any object's Zone 1 or the wall band around the floor, free (254) on the
  floor, unknown (128) outside the building. 128 rather than map_saver's 205, which reloads as free
  with ``free_thresh`` 0.25.
- ``keepout_mask.pgm`` / ``keepout_mask.yaml``: KeepoutFilter mask (mode scale), same grid: black (0,
  occupancy 100, lethal) on every pixel that overlaps an instrument's Zone 2 (which holds its Zone 1),
  white (255, occupancy 0) elsewhere. Costmap filters act on the robot centre, like VRT (paper Eq. 5).
- ``goals.yaml``: each goal object's Eq. 1 pose as a ``geometry_msgs/PoseStamped``, facing its face.
- ``nav2_params.yaml``: the mask server, filter info server and costmap settings to merge.
- ``map.png``: a preview (map, keep-out, goal arrows).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import shapely  # noqa: E402
import yaml  # noqa: E402
from matplotlib.patches import Circle, FancyArrow, Patch  # noqa: E402
from shapely.ops import unary_union  # noqa: E402

from biovln_ms.errors import BioVLNError  # noqa: E402
from biovln_ms.io_utils import atomic_write_bytes, atomic_write_text, save_figure  # noqa: E402
from biovln_ms.scene.rules import floor_polygon, obstacle_footprints  # noqa: E402
from biovln_ms.scene.spec import ObjectSpec, SceneSpec  # noqa: E402

FREE, OCCUPIED, UNKNOWN = 254, 0, 128  # map.pgm, trinary: darkness < 0.25 free, > 0.65 occupied
KEEPOUT, ALLOWED = 0, 255  # keepout_mask.pgm, scale: black -> 100 (lethal), white -> 0
OCCUPIED_THRESH, FREE_THRESH = 0.65, 0.25
MIN_RESOLUTION, MAX_RESOLUTION = 0.005, 1.0  # m per pixel
MAX_PIXELS = 16 * 2**20  # per image: a 200 x 200 m scene at 0.05 m
MARGIN_CELLS = 5  # unknown border around the wall band
DEFAULT_WALL = 0.1  # m: wall band of a spec without walls
#: m: a zone edge this close to a pixel centre counts as covering it, so that the 1e-7 rad tilt of a spec's
#: rounded yaw does not notch the raster of an edge lying on a row of centres
EDGE_TOL = 1e-5


@dataclass(frozen=True)
class MapGrid:
    """The raster frame shared by the map and the mask (see the module docstring)."""

    origin: tuple[float, float]
    resolution: float
    width: int
    height: int

    def world_to_pixel(self, xy) -> tuple[np.ndarray, np.ndarray]:
        """(row, col) of the pixels holding world points (N, 2)."""
        ij = np.floor((np.atleast_2d(np.asarray(xy, float)) - self.origin) / self.resolution).astype(int)
        return self.height - 1 - ij[:, 1], ij[:, 0]

    def pixel_to_world(self, row, col) -> np.ndarray:
        """World centres (N, 2) of pixels (row, col)."""
        col, row = np.asarray(col, float), np.asarray(row, float)
        return np.stack(
            [
                self.origin[0] + (col + 0.5) * self.resolution,
                self.origin[1] + (self.height - 1 - row + 0.5) * self.resolution,
            ],
            axis=-1,
        )

    def centres(self) -> np.ndarray:
        """World centres (H, W, 2) of every pixel, row 0 on top."""
        rows, cols = np.meshgrid(np.arange(self.height), np.arange(self.width), indexing="ij")
        return self.pixel_to_world(rows, cols)

    @property
    def extent(self) -> tuple[float, float, float, float]:
        """(left, right, bottom, top) in metres, for matplotlib's imshow."""
        ox, oy = self.origin
        return ox, ox + self.width * self.resolution, oy, oy + self.height * self.resolution


@dataclass(frozen=True)
class Nav2Maps:
    """The rasters and goals of one scene (what the files hold)."""

    grid: MapGrid
    occupancy: np.ndarray  # uint8 (H, W): FREE / OCCUPIED / UNKNOWN
    keepout: np.ndarray  # bool (H, W)
    goals: list[dict]


def _grid(spec: SceneSpec, resolution: float, pad: float) -> MapGrid:
    if not MIN_RESOLUTION <= resolution <= MAX_RESOLUTION:
        raise BioVLNError(
            f"resolution {resolution} m is out of range",
            field="--resolution",
            fix=f"use {MIN_RESOLUTION} to {MAX_RESOLUTION} m per pixel (Nav2 maps use 0.05)",
        )
    minx, miny, maxx, maxy = floor_polygon(spec).bounds
    i0, j0 = math.floor((minx - pad) / resolution), math.floor((miny - pad) / resolution)
    w = math.ceil((maxx + pad) / resolution) - i0
    h = math.ceil((maxy + pad) / resolution) - j0
    if w * h > MAX_PIXELS:
        raise BioVLNError(
            f"a {w} x {h} pixel map at {resolution} m is larger than the limit of {MAX_PIXELS} pixels",
            field="--resolution",
            fix="use a coarser --resolution",
        )
    return MapGrid((round(i0 * resolution, 9), round(j0 * resolution, 9)), resolution, w, h)


def _keepout_cells(grid: MapGrid, zones: list[np.ndarray]) -> np.ndarray:
    """Pixels touching any convex polygon (corners (k, 2)): centres in the polygon grown by a pixel
    square (Minkowski sum: the hull of the corners offset by the square's corners)."""
    xy = grid.centres()
    half = grid.resolution / 2 + EDGE_TOL
    square = np.array([[-half, -half], [half, -half], [half, half], [-half, half]])
    grown = [shapely.convex_hull(shapely.multipoints((c[:, None] + square).reshape(-1, 2))) for c in zones]
    if not grown:
        return np.zeros((grid.height, grid.width), bool)
    return shapely.intersects_xy(unary_union(grown), xy[..., 0], xy[..., 1])


def _r(v: float) -> float:
    return round(float(v), 6) + 0.0  # + 0.0: no "-0.0"


def _goal(o: ObjectSpec) -> dict:
    """A goal object's PoseStamped in ``map``: at its Eq. 1 goal, yaw facing the operational face (-f)."""
    yaw = math.atan2(-o.face[1], -o.face[0])
    return {
        "id": o.id,
        "category": o.category,
        "success_radius": _r(o.success_radius),
        "pose": {
            "header": {"frame_id": "map", "stamp": {"sec": 0, "nanosec": 0}},
            "pose": {
                "position": {"x": _r(o.goal[0]), "y": _r(o.goal[1]), "z": 0.0},
                "orientation": {"x": 0.0, "y": 0.0, "z": _r(math.sin(yaw / 2)), "w": _r(math.cos(yaw / 2))},
            },
        },
    }


def _pgm(img: np.ndarray) -> bytes:
    h, w = img.shape
    return f"P5\n{w} {h}\n255\n".encode() + np.ascontiguousarray(img, np.uint8).tobytes()


def _one_line(text: str) -> str:
    """``text`` with its line breaks, CRs, NULs and other control characters escaped (a spec's name)."""
    return text if text.isprintable() else ascii(text)[1:-1]


def _comment(text: str) -> str:
    """``text`` as one YAML comment line: escaped, so that it can neither end the comment and add keys nor
    make the file unreadable."""
    return f"# {_one_line(text)}\n"


def _map_yaml(image: str, mode: str, grid: MapGrid, comment: str) -> str:
    ox, oy = grid.origin
    meta = {
        "image": image,
        "mode": mode,
        "resolution": float(grid.resolution),
        "origin": [float(ox), float(oy), 0.0],
        "negate": 0,
        "occupied_thresh": OCCUPIED_THRESH,
        "free_thresh": FREE_THRESH,
    }
    return _comment(comment) + yaml.safe_dump(meta, sort_keys=False, default_flow_style=None)


def _params_yaml(robot_radius: float) -> str:
    def costmap() -> dict:  # a fresh dict each time: no YAML anchors, which ROS 2's parameter parser refuses
        return {
            "robot_radius": robot_radius,
            "filters": ["keepout_filter"],
            "keepout_filter": {
                "plugin": "nav2_costmap_2d::KeepoutFilter",
                "enabled": True,
                "filter_info_topic": "/costmap_filter_info",
            },
        }

    params = {
        "costmap_filter_info_server": {
            "ros__parameters": {
                "type": 0,
                "filter_info_topic": "/costmap_filter_info",
                "mask_topic": "/keepout_filter_mask",
                "base": 0.0,
                "multiplier": 1.0,
            }
        },
        "filter_mask_server": {
            "ros__parameters": {
                "frame_id": "map",
                "topic_name": "/keepout_filter_mask",
                "yaml_filename": "keepout_mask.yaml",
            }
        },
        "global_costmap": {"global_costmap": {"ros__parameters": costmap()}},
        "local_costmap": {"local_costmap": {"ros__parameters": costmap()}},
    }
    return (
        "# Merge into your Nav2 parameters. map.pgm is raw occupancy: the costmaps' inflation layer\n"
        f"# grows it by robot_radius ({robot_radius} m, the radius the scene was laid out for).\n"
        "# Give yaml_filename as an absolute path, or start the filter mask server in this folder.\n"
        + yaml.safe_dump(params, sort_keys=False)
    )


def _preview(spec: SceneSpec, m: Nav2Maps, path: Path) -> Path:
    grid = m.grid
    aspect = grid.height / grid.width
    fig, ax = plt.subplots(figsize=(12, max(4.0, 9 * aspect + 1.5)))
    ax.imshow(m.occupancy, cmap="gray", vmin=0, vmax=255, extent=grid.extent, interpolation="nearest")
    overlay = np.zeros((*m.keepout.shape, 4))
    overlay[m.keepout] = (0.85, 0.1, 0.1, 0.45)
    ax.imshow(overlay, extent=grid.extent, interpolation="nearest")
    for g in m.goals:
        p, q = g["pose"]["pose"]["position"], g["pose"]["pose"]["orientation"]
        yaw = 2 * math.atan2(q["z"], q["w"])
        ax.add_patch(Circle((p["x"], p["y"]), spec.robot_radius, fill=False, ec="#1f77b4", lw=1.0, ls="--"))
        ax.add_patch(
            FancyArrow(
                p["x"],
                p["y"],
                0.3 * math.cos(yaw),
                0.3 * math.sin(yaw),
                width=0.03,
                head_width=0.12,
                head_length=0.1,
                color="#1f77b4",
                length_includes_head=True,
            )
        )
        ax.annotate(g["id"], (p["x"], p["y"]), xytext=(4, -10), textcoords="offset points", fontsize=7)
    ax.legend(
        handles=[
            Patch(fc="white", ec="black", label="free"),
            Patch(fc="black", label="occupied (raw: Zone 1, walls)"),
            Patch(fc=(0.5, 0.5, 0.5), label="unknown"),
            Patch(fc=(0.85, 0.1, 0.1, 0.45), label="keep-out (Zones 1-2)"),
            Patch(fc="#1f77b4", label=f"goal pose, robot r = {spec.robot_radius} m"),
        ],
        loc="upper left",
        bbox_to_anchor=(1.01, 1.0),
        fontsize=8,
    )
    ax.set_xlabel("x (m, frame map)")
    ax.set_ylabel("y (m)")
    ax.set_title(f"{_one_line(spec.name)}: Nav2 map {grid.width} x {grid.height} px at {grid.resolution} m")
    fig.tight_layout()
    return save_figure(fig, path, dpi=130)


def nav2_maps(spec: SceneSpec, resolution: float = 0.05) -> Nav2Maps:
    """Rasterise the scene: occupancy by pixel centre, keep-out by pixel overlap; the goal poses."""
    floor = floor_polygon(spec)
    wall = max((w.thickness for w in spec.walls), default=DEFAULT_WALL)
    band = max(wall, 2 * resolution)  # at least two pixels: the floor stays closed in the raster
    grid = _grid(spec, resolution, band + MARGIN_CELLS * resolution)
    xy = grid.centres()
    x, y = xy[..., 0], xy[..., 1]
    ring = floor.buffer(band, join_style="mitre").difference(floor)
    blocked = unary_union([ring, *obstacle_footprints(spec)]).buffer(EDGE_TOL, join_style="mitre")
    occupancy = np.full((grid.height, grid.width), UNKNOWN, np.uint8)
    occupancy[shapely.contains_xy(floor, x, y)] = FREE
    occupancy[shapely.intersects_xy(blocked, x, y)] = OCCUPIED
    keepout = _keepout_cells(grid, [o.placed().zone2_corners() for o in spec.instruments])
    return Nav2Maps(grid, occupancy, keepout, [_goal(o) for o in spec.goal_objects()])


def export_nav2(spec: SceneSpec, out: str | Path, resolution: float = 0.05) -> list[Path]:
    """Write the Nav2 files of a scene into folder ``out`` (each atomically; the same bytes for the same
    spec and resolution); returns their paths."""
    out = Path(out)
    m = nav2_maps(spec, resolution)
    name, radius = spec.name, spec.robot_radius
    return [
        atomic_write_bytes(out / "map.pgm", _pgm(m.occupancy)),
        atomic_write_text(
            out / "map.yaml",
            _map_yaml(
                "map.pgm",
                "trinary",
                m.grid,
                f"{name}: raw occupancy (not inflated); set robot_radius {radius} m in the costmaps",
            ),
        ),
        atomic_write_bytes(out / "keepout_mask.pgm", _pgm(np.where(m.keepout, KEEPOUT, ALLOWED))),
        atomic_write_text(
            out / "keepout_mask.yaml",
            _map_yaml(
                "keepout_mask.pgm",
                "scale",
                m.grid,
                f"{name}: KeepoutFilter mask (costmap_filter_info_server type 0): instruments' Zones 1-2",
            ),
        ),
        atomic_write_text(
            out / "goals.yaml",
            _comment(
                f"{name}: goal poses (geometry_msgs/PoseStamped), at the Eq. 1 goal facing the operational"
            )
            + "# face; orientation is the quaternion x, y, z, w of the yaw about z\n"
            + yaml.safe_dump({"frame_id": "map", "goals": m.goals}, sort_keys=False),
        ),
        atomic_write_text(out / "nav2_params.yaml", _params_yaml(radius)),
        _preview(spec, m, out / "map.png"),
    ]
