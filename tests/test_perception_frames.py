"""The detector's labelled frames (biovln_ms.perception.frames / frame_dataset, `biovln-ms perception
dataset`): held-out scenes and looks, one-line errors, and a tiny rendered build that is deterministic and
whose masks, boxes and depth agree with the scene."""

from __future__ import annotations

import hashlib
import json
import math
from pathlib import Path

import numpy as np
import pytest
from PIL import Image
from shapely.geometry import Point, Polygon
from typer.testing import CliRunner

from biovln_ms.assetgen.variation import PAINTS
from biovln_ms.episodes.samplers import SceneSamplers, SingleGoalEpisodes
from biovln_ms.perception import frames as F
from biovln_ms.perception.frame_dataset import build_frames_dataset, check_request, parse_resolution
from biovln_ms.scene.generator import generate_scene

runner = CliRunner()


@pytest.fixture(scope="module")
def sources() -> list[F.SceneSource]:
    out, samplers = [], SceneSamplers()
    for template, seed in (("single_room", 0), ("single_room", 1), ("molecular_biology", 5000)):
        spec = generate_scene(template, seed)
        out.append(F.SceneSource(spec, tuple(SingleGoalEpisodes().draw(samplers, spec, 4, seed))))
    return out


def test_held_out_scenes_cover_every_shared_category(sources):
    held = F.hold_out_scenes(sources)
    assert held and len(held) < len(sources)
    train = [s for s in sources if s.spec.name not in held]
    test = [s for s in sources if s.spec.name in held]
    for s in sources:  # every category of a held-out scene is still seen in training
        for c in s.goal_categories:
            assert any(c in t.goal_categories for t in train), c
    for c in {
        c for s in sources for c in s.goal_categories if sum(c in x.goal_categories for x in sources) > 1
    }:
        assert any(c in t.goal_categories for t in test), c
    assert F.hold_out_scenes(list(reversed(sources))) == held  # order does not matter


def test_groups_keep_held_out_scenes_and_looks_apart(sources):
    by_name = {s.spec.name: s for s in sources}
    held = F.hold_out_scenes(sources)
    parts = set()
    for g in range(60):
        group = F.draw_group(7, g, by_name, held)
        parts.add(group.part)
        assert (group.scene in held) == (group.part == "test_scenes")
        paints = {k % PAINTS for k in group.looks.values()}
        if group.part == "test_looks":
            assert paints <= set(F.HELD_OUT_PAINTS)
        else:
            assert not paints & set(F.HELD_OUT_PAINTS)
        spec = F.dressed_spec(by_name[group.scene].spec, group.dressing)
        assert set(group.looks) == {o.id for o in spec.objects()}
        frame = F.plan_frame(7, g * F.FRAMES_PER_GROUP, group, by_name)
        assert F.CAMERA_HEIGHT[0] <= frame.eye[2] <= F.CAMERA_HEIGHT[1]
        nav = F._scene(by_name[group.scene].spec, group.dressing)[1]
        # on the robot's free space (a path may run along its edge): never inside a body or the dressing
        assert nav.free.distance(Point(frame.eye[:2])) < 1e-4, (group, frame.eye)
    assert parts == set(F.PARTS)
    assert F.draw_group(7, 3, by_name, held) == F.draw_group(7, 3, by_name, held)


def test_annotations_of_an_instance_image():
    inst = np.zeros((6, 8), np.uint16)
    inst[1:3, 2:5] = 1
    inst[5, 7] = 4
    anns = F.instance_annotations(inst, {1: 3, 4: 9})
    assert [(a["instance"], a["category_id"], a["bbox"], a["area"]) for a in anns] == [
        (1, 3, [2, 1, 3, 2], 6),
        (4, 9, [7, 5, 1, 1], 1),
    ]
    for a in anns:
        assert (F.decode_mask(a["segmentation"]) == (inst == a["instance"])).all()


@pytest.mark.parametrize(
    "args",
    [(0, 64, 48, 1, 0), (5, 16, 48, 1, 0), (5, 64, 48, 0, 0), (5, 64, 48, 1, -1), (True, 64, 48, 1, 0)],
)
def test_bad_requests_are_one_line_errors(args):
    with pytest.raises(F.FramesError) as e:
        check_request(*args)
    assert "\n" not in str(e.value) and "fix:" in str(e.value)


def test_bad_resolution_and_split_through_the_cli(held_out_dataset, tmp_path):
    from biovln_ms.cli import app

    with pytest.raises(F.FramesError, match="WIDTHxHEIGHT"):
        parse_resolution("320by240")
    data = held_out_dataset(ms_val=2)
    for extra, words in (
        (["--frame-size", "abc"], "resolution"),
        (["--frames", "0"], "frames"),
        (["--split", "nosuch"], "no split 'nosuch'"),
    ):
        r = runner.invoke(app, ["perception", "dataset", data, "-o", str(tmp_path / "x"), *extra])
        assert isinstance(r.exception, F.FramesError), r.output
        assert words in str(r.exception) and "\n" not in str(r.exception)
    assert not (tmp_path / "x").exists()


def test_a_held_out_part_without_frames_is_named(held_out_dataset, tmp_path, monkeypatch):
    import biovln_ms.perception.frame_dataset as FD
    from biovln_ms.cli import app

    row = {"frames": 8, "instances": {"centrifuge": 3}, "scenes": ["s"]}
    parts = {"train": row, "test_scenes": row, "test_looks": {**row, "frames": 0}}
    monkeypatch.setattr(FD, "build_frames_dataset", lambda *a, **k: {"parts": parts})
    data = held_out_dataset(ms_val=2)
    r = runner.invoke(app, ["perception", "dataset", data, "-o", str(tmp_path / "x"), "--split", "ms_val"])
    assert r.exit_code == 0, r.output
    warned = [line for line in r.output.splitlines() if line.startswith("warning:")]
    assert len(warned) == 1 and "test_looks has no frames" in warned[0] and "--frames" in warned[0]


def _camera_rays(w: int, h: int, hfov: float, yaw: float, pitch: float) -> np.ndarray:
    """(H, W, 3) world directions with unit depth along the optical axis (SAPIEN: x forward, y left, z up)."""
    f = w / (2 * math.tan(hfov / 2))
    u, v = np.meshgrid(np.arange(w) + 0.5, np.arange(h) + 0.5)
    fwd = np.array([math.cos(pitch) * math.cos(yaw), math.cos(pitch) * math.sin(yaw), math.sin(pitch)])
    left = np.cross([0.0, 0.0, 1.0], fwd)
    left /= np.linalg.norm(left)
    up = np.cross(fwd, left)
    return fwd + ((w / 2 - u) / f)[..., None] * left + ((h / 2 - v) / f)[..., None] * up


def _footprint(obj, margin: float = 0.05) -> Polygon:
    """The object's footprint (its size turned by its yaw about its position), grown by ``margin``."""
    c, s = math.cos(obj.yaw), math.sin(obj.yaw)
    hx, hy = obj.size[0] / 2 + margin, obj.size[1] / 2 + margin
    x, y = obj.position[:2]
    return Polygon(
        [
            (x + c * a * hx - s * b * hy, y + s * a * hx + c * b * hy)
            for a, b in ((-1, -1), (1, -1), (1, 1), (-1, 1))
        ]
    )


@pytest.mark.slow
def test_a_tiny_build_is_deterministic_and_its_labels_match_the_scene(sources, tmp_path):
    a = build_frames_dataset(tmp_path / "a", sources, frames=10, seed=3, resolution=(96, 72))
    b = build_frames_dataset(tmp_path / "b", sources, frames=10, seed=3, resolution=(96, 72))
    files = sorted(p.relative_to(tmp_path / "a") for p in (tmp_path / "a").rglob("*") if p.is_file())
    assert files == sorted(p.relative_to(tmp_path / "b") for p in (tmp_path / "b").rglob("*") if p.is_file())
    for rel in files:
        assert (tmp_path / "a" / rel).read_bytes() == (tmp_path / "b" / rel).read_bytes(), rel
    assert a == b and sum(r["frames"] for r in a["parts"].values()) == 10
    assert not list(tmp_path.glob(".*partial*"))

    root = tmp_path / "a"
    by_name = {s.spec.name: s for s in sources}
    checked = 0
    for part in F.PARTS:
        coco = json.loads((root / f"annotations/{part}.json").read_text())
        cats = {c["id"]: c["name"] for c in coco["categories"]}
        anns: dict[int, list[dict]] = {}
        for ann in coco["annotations"]:
            anns.setdefault(ann["image_id"], []).append(ann)
        for im in coco["images"]:
            assert im["part"] == part and (im["scene"] in a["held_out_scenes"]) == (part == "test_scenes")
            inst = np.asarray(Image.open(root / im["instances_file"]))
            depth = np.asarray(Image.open(root / im["depth_file"]))
            assert inst.shape == depth.shape == (72, 96) and inst.dtype == depth.dtype == np.uint16
            mine = anns.get(im["id"], [])
            assert sorted(int(x["instance"]) for x in mine) == sorted(int(k) for k in np.unique(inst) if k)
            spec = F.dressed_spec(by_name[im["scene"]].spec, im["dressing"])
            rays = _camera_rays(96, 72, math.radians(a["camera"]["hfov_deg"]), im["yaw"], im["pitch"])
            for ann in mine:
                m = F.decode_mask(ann["segmentation"])
                assert (m == (inst == ann["instance"])).all()
                ys, xs = np.nonzero(m)
                x, y, w, h = ann["bbox"]
                assert (x, y, x + w - 1, y + h - 1) == (xs.min(), ys.min(), xs.max(), ys.max())
                obj = spec.get(ann["object_id"])
                assert cats[ann["category_id"]] == obj.category
                assert (im["looks"][obj.id] % PAINTS in F.HELD_OUT_PAINTS) == (part == "test_looks")
                if im["noise"] == "ideal" and ann["area"] >= 20:  # back-projected pixels land on the object
                    pts = np.asarray(im["eye"]) + rays[m] * (depth[m, None] / 1000.0)
                    inside = np.mean([_footprint(obj).contains(Point(p[0], p[1])) for p in pts])
                    assert inside > 0.95, (im["id"], obj.id, inside)
                    checked += 1
    assert checked > 0
    for rel, digest in a["files"].items():
        assert hashlib.sha256((root / rel).read_bytes()).hexdigest() == digest
    assert Path(root / "manifest.json").exists()
