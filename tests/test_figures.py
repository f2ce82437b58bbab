"""The report's and the maps' figures, checked on their artists after a draw: every legend, axis label and
title inside the figure, no two labels overlapping, and each trajectory's end pose and outcome drawn."""

import math
from functools import lru_cache
from itertools import combinations

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
import pytest
from matplotlib.text import Text

from biovln_ms.eval import figures
from biovln_ms.scene.generator import generate_scene
from biovln_ms.scene.topdown import LABEL_GID, map_figure


@lru_cache(maxsize=None)
def _scene(template: str, seed: int):
    return generate_scene(template, seed=seed)


def _drawn(fig):
    fig.canvas.draw()
    return fig.canvas.get_renderer()


def _inside(box, frame, tol: float = 0.5) -> bool:
    return (
        box.x0 >= frame.x0 - tol
        and box.y0 >= frame.y0 - tol
        and box.x1 <= frame.x1 + tol
        and box.y1 <= frame.y1 + tol
    )


def _assert_nothing_cut_off(fig, renderer):
    """Every axes' title, axes (tick labels and axis label) and legend lie inside the figure."""
    frame = fig.bbox
    for ax in fig.axes:
        parts = {"title": ax.title, "x axis": ax.xaxis, "y axis": ax.yaxis, "legend": ax.get_legend()}
        for what, artist in parts.items():
            box = artist.get_tightbbox(renderer) if artist is not None and artist.get_visible() else None
            if box is not None and box.width > 0:
                assert _inside(box, frame), f"{what} of '{ax.get_title()}' cut off"


def _labels(fig) -> list:
    return [t for ax in fig.axes for t in ax.texts if t.get_gid() == LABEL_GID]


def _assert_labels_apart(fig, renderer):
    """No two labels' text boxes overlap, and each lies inside its axes."""
    boxes = []
    for t in _labels(fig):
        box = Text.get_window_extent(t, renderer)  # the text alone, not its leader line
        assert _inside(box, t.axes.get_window_extent(renderer)), f"label outside its axes: {t.get_text()}"
        boxes.append((t.get_text(), box))
    for (a, ba), (b, bb) in combinations(boxes, 2):
        w = min(ba.x1, bb.x1) - max(ba.x0, bb.x0)
        h = min(ba.y1, bb.y1) - max(ba.y0, bb.y0)
        assert w <= 0.5 or h <= 0.5, f"labels {a!r} and {b!r} overlap"


def test_a_map_keeps_its_legend_and_labels_inside_and_its_goal_labels_apart():
    spec = _scene("two_room", 1)  # goals a few decimetres apart
    fig = map_figure(spec)
    r = _drawn(fig)
    _assert_nothing_cut_off(fig, r)
    assert sorted(t.get_text() for t in _labels(fig)) == sorted(o.id for o in spec.goal_objects())
    _assert_labels_apart(fig, r)
    plt.close(fig)


def _crowded_runs() -> dict:
    """Runs of ten methods, with and without noise, on two splits: many near VRT 0 and MCR 0.5-1.4, as
    real runs are."""
    rng = np.random.default_rng(3)
    methods = ["random", "frontier", "vlfm", "oracle", "zone3_oracle", "ppo@opface-rl"]
    runs = {}
    for split in ("ms_val", "two_room"):
        for m in methods:
            for run in (m, f"{m}+realistic"):
                far = rng.random() < 0.6
                mcr = rng.uniform(0.5, 1.4) if far else rng.uniform(0.15, 0.5)
                vrt = 0.0 if far else rng.uniform(0, 100)
                runs[(run, split)] = [{"mcr": mcr, "vrt": vrt}]
    return runs


def test_safety_labels_never_overlap_and_the_legend_is_inside(monkeypatch):
    monkeypatch.setattr(figures, "aggregate", lambda recs: dict(recs[0]))
    runs = _crowded_runs()
    fig = figures.safety_figure(runs)
    r = _drawn(fig)
    _assert_nothing_cut_off(fig, r)
    labels = _labels(fig)
    assert len(labels) == len(runs)
    _assert_labels_apart(fig, r)
    titles = [ax.get_title() for ax in fig.axes]
    assert titles == ["MS VAL", "Two-Room"]
    plt.close(fig)


def _episode(scene: str, start, end, heading: float | None, success: bool) -> dict:
    path = np.linspace(start, end, 6).round(4).tolist()
    rec = {"scene_id": scene, "positions": path, "success": success}
    if heading is not None:
        rec["headings"] = [0.0] * 5 + [heading]
    return rec


def test_trajectories_show_each_end_pose_and_outcome(monkeypatch):
    monkeypatch.setattr(figures, "record_error", lambda r: r.get("error"))
    spec = _scene("single_room", 150)
    recs = [
        _episode(spec.name, (5.9, 3.0), (4.6, 4.4), math.pi / 2, True),
        _episode(spec.name, (3.0, 1.5), (6.0, 4.0), -math.pi / 4, False),
        _episode(spec.name, (6.5, 3.0), (7.0, 1.9), None, True),  # no headings: its last move's direction
        {"scene_id": spec.name, "error": "crashed"},  # no trajectory
    ]
    fig = figures.trajectories_figure(recs, lambda scene: spec, "test")
    r = _drawn(fig)
    _assert_nothing_cut_off(fig, r)
    _assert_labels_apart(fig, r)
    (ax,) = fig.axes
    marks = [ln for ln in ax.lines if ln.get_gid() == figures.END_MARK_GID]
    assert [(m.get_marker(), tuple(np.ravel(m.get_data()))) for m in marks] == [
        ("o", (4.6, 4.4)),
        ("X", (6.0, 4.0)),
        ("o", (7.0, 1.9)),
    ]
    arrows = [p for p in ax.patches if p.get_gid() == figures.END_POSE_GID]
    assert len(arrows) == 3
    last_move = math.atan2(1.9 - 3.0, 7.0 - 6.5)
    for arrow, rec, heading in zip(arrows, recs, (math.pi / 2, -math.pi / 4, last_move)):
        end = np.asarray(rec["positions"][-1])
        tip = max(arrow.get_xy(), key=lambda v: np.linalg.norm(v - end))
        assert math.atan2(*(tip - end)[::-1]) == pytest.approx(heading, abs=1e-6)
    assert {t.get_text() for t in ax.get_legend().get_texts()} >= {
        "end: success",
        "end: failure",
        "final heading",
    }
    plt.close(fig)
