"""`biovln-ms export nav2`: the files read back as Nav2 reads them (map_server's trinary
and scale rules), goals land on free cells outside the keep-out, coordinates round-trip within a cell."""

from __future__ import annotations

import json
import math
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import shapely
import yaml
from typer.testing import CliRunner

from biovln_ms.bridges.nav2 import nav2_maps
from biovln_ms.cli import app
from biovln_ms.errors import BioVLNError
from biovln_ms.scene.generator import generate_scene
from biovln_ms.scene.rules import floor_polygon, scene_free_space
from biovln_ms.scene.spec import save_spec

FILES = [
    "map.pgm",
    "map.yaml",
    "keepout_mask.pgm",
    "keepout_mask.yaml",
    "goals.yaml",
    "nav2_params.yaml",
    "map.png",
]


def read_pgm(path: Path) -> np.ndarray:
    """A binary (P5) 8-bit PGM as (H, W) uint8, row 0 on top."""
    data = path.read_bytes()
    m = re.match(rb"P5\s+(\d+)\s+(\d+)\s+(\d+)\s", data)
    assert m, f"{path} is not a binary PGM"
    w, h, maxval = map(int, m.groups())
    assert maxval == 255
    raster = data[m.end() :]
    assert len(raster) == w * h
    return np.frombuffer(raster, np.uint8).reshape(h, w)


def load_map(yaml_path: Path) -> tuple[dict, np.ndarray]:
    """A map_server map as an OccupancyGrid (row 0 on top): its YAML and cells in -1 / 0..100."""
    meta = yaml.safe_load(yaml_path.read_text())
    img = read_pgm(yaml_path.parent / meta["image"])
    occ = (255.0 - img) / 255.0  # negate 0: darkness
    hi, lo = meta["occupied_thresh"], meta["free_thresh"]
    if meta["mode"] == "trinary":
        cells = np.where(occ > hi, 100, np.where(occ < lo, 0, -1))
    else:  # scale (no alpha channel): linear in between
        cells = np.where(occ > hi, 100, np.where(occ < lo, 0, np.rint(99 * (occ - lo) / (hi - lo))))
    return meta, cells.astype(int)


def to_pixel(meta: dict, height: int, xy) -> tuple[np.ndarray, np.ndarray]:
    xy = np.atleast_2d(np.asarray(xy, float))
    ij = np.floor((xy - meta["origin"][:2]) / meta["resolution"]).astype(int)
    return height - 1 - ij[:, 1], ij[:, 0]


def to_world(meta: dict, height: int, row, col) -> np.ndarray:
    res, (ox, oy) = meta["resolution"], meta["origin"][:2]
    return np.stack([ox + (np.asarray(col) + 0.5) * res, oy + (height - 1 - np.asarray(row) + 0.5) * res], -1)


def sample_rect(corners: np.ndarray, n: int, rng) -> np.ndarray:
    """Uniform points inside a rectangle given by its 4 corners (in order)."""
    u, v = rng.random((2, n, 1))
    return corners[0] + u * (corners[1] - corners[0]) + v * (corners[3] - corners[0])


@pytest.fixture(scope="module", params=[("two_room", 0), ("suite", 3)], ids=lambda p: p[0])
def exported(request, tmp_path_factory):
    spec = generate_scene(*request.param)
    root = tmp_path_factory.mktemp(spec.name)
    spec_path = save_spec(spec, root / "spec.json")
    r = CliRunner().invoke(app, ["export", "nav2", str(spec_path), "-o", str(root / "nav2")])
    assert r.exit_code == 0, r.output
    assert f"wrote {len(FILES)} files" in r.output
    return spec, root / "nav2"


def test_files_follow_map_server_format(exported):
    spec, out = exported
    assert sorted(p.name for p in out.iterdir()) == sorted(FILES)
    meta, cells = load_map(out / "map.yaml")
    mask_meta, mask = load_map(out / "keepout_mask.yaml")
    assert meta["image"] == "map.pgm" and meta["mode"] == "trinary"
    assert mask_meta["image"] == "keepout_mask.pgm" and mask_meta["mode"] == "scale"
    for m in (meta, mask_meta):
        assert m["resolution"] == 0.05 and m["negate"] == 0
        assert (m["occupied_thresh"], m["free_thresh"]) == (0.65, 0.25)
        assert len(m["origin"]) == 3 and m["origin"][2] == 0.0
    assert mask_meta["origin"] == meta["origin"] and mask.shape == cells.shape
    h, w = cells.shape
    minx, miny, maxx, maxy = scene_free_space(spec).bounds
    ox, oy = meta["origin"][:2]
    assert ox < minx and oy < miny and ox + w * 0.05 > maxx and oy + h * 0.05 > maxy
    assert set(np.unique(cells)) == {-1, 0, 100}  # unknown (128) does not reload as free
    assert set(np.unique(mask)) == {0, 100}
    params = yaml.safe_load((out / "nav2_params.yaml").read_text())
    assert "&" not in (out / "nav2_params.yaml").read_text()  # no YAML anchors for ROS 2's parser
    info = params["costmap_filter_info_server"]["ros__parameters"]
    assert (info["type"], info["base"], info["multiplier"]) == (0, 0.0, 1.0)
    assert params["filter_mask_server"]["ros__parameters"]["topic_name"] == info["mask_topic"]
    for name in ("global_costmap", "local_costmap"):
        costmap = params[name][name]["ros__parameters"]
        assert costmap["robot_radius"] == spec.robot_radius
        assert costmap["keepout_filter"]["plugin"] == "nav2_costmap_2d::KeepoutFilter"
        assert costmap["keepout_filter"]["filter_info_topic"] == info["filter_info_topic"]


def test_map_matches_the_scene_geometry(exported):
    """Navigable floor reads free, bodies occupied, the floor is closed: the frame (origin, flip) is right."""
    spec, out = exported
    meta, cells = load_map(out / "map.yaml")
    h = cells.shape[0]
    rng = np.random.default_rng(0)
    free = scene_free_space(spec)  # >= robot radius from every obstacle
    minx, miny, maxx, maxy = free.bounds
    pts = rng.uniform([minx, miny], [maxx, maxy], (4000, 2))
    pts = pts[shapely.contains_xy(free, pts[:, 0], pts[:, 1])]
    assert (cells[to_pixel(meta, h, pts)] == 0).all()
    for o in spec.objects():
        body = shapely.Polygon(o.placed().zone1_corners()).buffer(-0.05)
        inner = sample_rect(o.placed().zone1_corners(), 200, rng)
        inner = inner[shapely.contains_xy(body, inner[:, 0], inner[:, 1])]
        assert (cells[to_pixel(meta, h, inner)] == 100).all(), o.id
    # free cells only connect to free, occupied or the border: none touches unknown (the walls are closed)
    f, u = cells == 0, cells == -1
    assert not (f[1:] & u[:-1]).any() and not (f[:-1] & u[1:]).any()
    assert not (f[:, 1:] & u[:, :-1]).any() and not (f[:, :-1] & u[:, 1:]).any()
    assert not (f[0].any() or f[-1].any() or f[:, 0].any() or f[:, -1].any())


def test_keepout_covers_zones_1_and_2(exported):
    spec, out = exported
    meta, mask = load_map(out / "keepout_mask.yaml")
    h = mask.shape[0]
    rng = np.random.default_rng(1)
    zones = [o.placed().zone2_corners() for o in spec.instruments]
    for o, z in zip(spec.instruments, zones):
        assert (mask[to_pixel(meta, h, np.vstack([sample_rect(z, 500, rng), z]))] == 100).all(), o.id
    # and no more than that: a marked pixel's centre is within half a pixel diagonal of some Zone 2
    rows, cols = np.nonzero(mask == 100)
    centres = to_world(meta, h, rows, cols)
    dist = shapely.distance(
        shapely.MultiPolygon([shapely.Polygon(z) for z in zones]), shapely.points(centres)
    )
    assert dist.max() <= 0.05 * math.sqrt(0.5) + 1e-4


def test_goals_land_on_free_cells_facing_the_face(exported):
    spec, out = exported
    meta, cells = load_map(out / "map.yaml")
    _, mask = load_map(out / "keepout_mask.yaml")
    h = cells.shape[0]
    doc = yaml.safe_load((out / "goals.yaml").read_text())
    objs = spec.goal_objects()
    assert doc["frame_id"] == "map" and [g["id"] for g in doc["goals"]] == [o.id for o in objs]
    for g, o in zip(doc["goals"], objs):
        assert g["category"] == o.category and g["success_radius"] == o.success_radius
        assert g["pose"]["header"]["frame_id"] == "map"
        p, q = g["pose"]["pose"]["position"], g["pose"]["pose"]["orientation"]
        xy = np.array([p["x"], p["y"]])
        assert np.allclose(xy, o.goal, atol=1e-6) and p["z"] == 0.0
        assert q["x"] == q["y"] == 0.0 and math.isclose(math.hypot(q["z"], q["w"]), 1.0, abs_tol=1e-5)
        row, col = to_pixel(meta, h, xy)
        assert cells[row, col] == 0 and mask[row, col] == 0, o.id
        yaw = 2 * math.atan2(q["z"], q["w"])
        heading = np.array([math.cos(yaw), math.sin(yaw)])
        assert np.dot(heading, o.face) == pytest.approx(-1.0, abs=1e-5)  # looks at the face
        hit = xy + heading * (o.approach_distance + 0.05)  # just past the face: inside the body
        assert shapely.Polygon(o.placed().zone1_corners()).contains(shapely.Point(hit)), o.id


def test_coordinates_round_trip_within_one_cell(exported):
    spec, out = exported
    meta, cells = load_map(out / "map.yaml")
    h, w = cells.shape
    grid = nav2_maps(spec).grid
    assert (grid.width, grid.height) == (w, h)
    pts = np.random.default_rng(2).uniform(meta["origin"][:2], [grid.extent[1], grid.extent[3]], (2000, 2))
    pts = np.vstack([pts, [o.goal for o in spec.goal_objects()]])
    row, col = to_pixel(meta, h, pts)
    assert ((row >= 0) & (row < h) & (col >= 0) & (col < w)).all()
    back = to_world(meta, h, row, col)
    assert np.abs(back - pts).max() <= 0.05 / 2 + 1e-9  # the cell centre: half a cell per axis
    mrow, mcol = grid.world_to_pixel(pts)  # the exporter's frame is the file's frame
    assert (mrow == row).all() and (mcol == col).all()
    assert np.allclose(grid.pixel_to_world(row, col), back)


def test_export_is_deterministic(exported, tmp_path):
    spec, out = exported
    spec_path = out.parent / "spec.json"
    r = CliRunner().invoke(app, ["export", "nav2", str(spec_path), "-o", str(tmp_path)])
    assert r.exit_code == 0, r.output
    for name in FILES:
        assert (tmp_path / name).read_bytes() == (out / name).read_bytes(), name


def test_resolution_option(tmp_path):
    spec = generate_scene("single_room", 154)
    spec_path = save_spec(spec, tmp_path / "spec.json")
    r = CliRunner().invoke(
        app, ["export", "nav2", str(spec_path), "-o", str(tmp_path / "n"), "--resolution", "0.1"]
    )
    assert r.exit_code == 0, r.output
    meta, cells = load_map(tmp_path / "n" / "map.yaml")
    _, mask = load_map(tmp_path / "n" / "keepout_mask.yaml")
    assert meta["resolution"] == 0.1 and mask.shape == cells.shape
    minx, miny, maxx, maxy = floor_polygon(spec).bounds
    h, w = cells.shape
    assert maxx - minx < w * 0.1 < maxx - minx + 2 and maxy - miny < h * 0.1 < maxy - miny + 2


def test_oversized_map_is_refused(monkeypatch):
    from biovln_ms.bridges import nav2

    monkeypatch.setattr(nav2, "MAX_PIXELS", 10_000)
    with pytest.raises(
        BioVLNError, match=r"field '--resolution': a \d+ x \d+ pixel map .* larger than the limit"
    ):
        nav2_maps(generate_scene("single_room", 154))


def test_bad_input_is_one_line(tmp_path):
    out = tmp_path / "out"
    missing, not_json, invalid = tmp_path / "nope.json", tmp_path / "text.json", tmp_path / "bad.json"
    not_json.write_text("{not json")
    spec = json.loads(generate_scene("single_room", 154).to_json())
    spec["instruments"][0]["size"][1] = -1.0
    invalid.write_text(json.dumps(spec))
    good = save_spec(generate_scene("single_room", 154), tmp_path / "good.json")
    cases = [
        ((missing,), [str(missing), "cannot read the scene spec"]),
        ((not_json,), [str(not_json), "field 'file'", "not valid JSON", "fix:"]),
        ((invalid,), [str(invalid), "field 'instruments[0].size[1]'", "fix:"]),
        ((good, "--resolution", "0"), ["field '--resolution'", "out of range", "fix:"]),
        ((good, "--resolution", "2"), ["field '--resolution'", "out of range", "fix:"]),
    ]
    for args, needles in cases:
        r = subprocess.run(
            [sys.executable, "-m", "biovln_ms.cli", "export", "nav2", *map(str, args), "-o", str(out)],
            capture_output=True,
            text=True,
        )
        lines = r.stderr.strip().splitlines()
        assert r.returncode == 2 and len(lines) == 1 and "Traceback" not in r.stderr, r.stderr
        for needle in needles:
            assert needle in lines[0], (needle, lines[0])
    assert not out.exists()  # nothing written on bad input
