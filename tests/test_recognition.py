"""The recognisability benchmark (the paper's Table 8 question): ranking of the true category's prompt,
top-k, and a tiny render-and-score pass through the goal views (64x48, one category, a scorer that reads
the frame)."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

REPO = Path(__file__).resolve().parents[1]
spec = importlib.util.spec_from_file_location("recognition", REPO / "benchmarks" / "recognition.py")
recognition = importlib.util.module_from_spec(spec)
sys.modules["recognition"] = recognition
spec.loader.exec_module(recognition)

CATS = ["refrigerator", "incubator", "centrifuge", "pipette"]


def _scored(category: str, scores: list[float]) -> recognition.Scored:
    return recognition.Scored(category, "fast", 0.0, np.zeros((4, 4, 3), np.uint8), np.asarray(scores, float))


def test_rank_counts_ties_against_the_truth():
    assert _scored("incubator", [0.1, 0.9, 0.3, 0.2]).rank(CATS) == 1
    assert _scored("centrifuge", [0.1, 0.9, 0.3, 0.2]).rank(CATS) == 2
    assert _scored("refrigerator", [0.1, 0.9, 0.3, 0.2]).rank(CATS) == 4
    assert _scored("pipette", [0.5, 0.5, 0.5, 0.5]).rank(CATS) == 4  # a scorer that cannot tell: last


def test_top_k_is_the_fraction_within_k():
    results = [
        _scored("incubator", [0.1, 0.9, 0.3, 0.2]),  # rank 1
        _scored("centrifuge", [0.1, 0.9, 0.3, 0.2]),  # rank 2
        _scored("refrigerator", [0.1, 0.9, 0.3, 0.2]),  # rank 4
        _scored("pipette", [0.0, 0.1, 0.2, 0.3]),  # rank 1
    ]
    assert recognition.top_k(results, CATS, 1) == 0.5
    assert recognition.top_k(results, CATS, 3) == 0.75
    assert recognition.top_k(results, CATS, 4) == 1.0


class Brightness:
    """A stand-in scorer: the frame's mean brightness, shifted per target (so targets rank by name)."""

    name = "brightness"

    def score(self, rgb: np.ndarray, target: str) -> float:
        return float(rgb.mean() / 255.0) * (1.0 + 0.01 * len(target))


def test_render_and_score_renders_each_view_under_each_preset(tmp_path):
    pytest.importorskip("sapien")
    prompts = ["pipette stand", "lab bench"]
    results = recognition.render_and_score(
        Brightness(), ["pipette", "lab_bench"], prompts, presets=("fast",), width=64, height=48
    )
    assert [(r.category, r.offset) for r in results] == [
        (c, o) for c in ("pipette", "lab_bench") for o in recognition.OFFSETS
    ]
    for r in results:
        assert r.rgb.shape == (48, 64, 3) and r.rgb.dtype == np.uint8 and r.rgb.max() > 0  # lit, not black
        want = [r.rgb.mean() / 255 * (1 + 0.01 * len(p)) for p in prompts]
        np.testing.assert_allclose(r.scores, want)
        assert r.rank(["pipette", "lab_bench"]) == 2 - (r.category == "pipette")  # "pipette stand" is longer
    sheet = tmp_path / "sheet.png"
    recognition.contact_sheet(results, ["pipette", "lab_bench"], sheet, thumb=80)
    img = Image.open(sheet)
    assert img.size == (3 * 80, 2 * (60 + 34))


class _FixedSegmenter:
    """Stand-in for the trained segmenter: the same instances for every frame."""

    def __init__(self, instances) -> None:
        self._instances = instances

    def instances(self, rgb):
        return self._instances


def test_the_detector_recognises_what_covers_the_frame_centre():
    from biovln_ms.perception.segmenter import Instance

    h, w = 40, 80
    centre, edge = np.zeros((h, w), bool), np.zeros((h, w), bool)
    centre[10:30, 20:60] = True  # the whole central window
    edge[:, :20] = True  # outside it: counts for nothing
    rec = recognition.DetectorRecognizer.__new__(recognition.DetectorRecognizer)
    rec.categories = CATS
    rec.segmenter = _FixedSegmenter([Instance("centrifuge", centre, 0.5), Instance("pipette", edge, 0.99)])
    scores = rec.scores(np.zeros((h, w, 3), np.uint8))
    np.testing.assert_allclose(scores, [0.0, 0.0, 0.5, 0.0])
    assert recognition.Scored("centrifuge", "fast", 0.0, None, scores).rank(CATS) == 1
    rec.segmenter = _FixedSegmenter([])  # nothing seen: every category last
    nothing = rec.scores(np.zeros((h, w, 3), np.uint8))
    assert recognition.Scored("centrifuge", "fast", 0.0, None, nothing).rank(CATS) == len(CATS)


def test_a_view_where_nothing_is_told_apart_has_no_best_guess():
    assert recognition.best_guess(np.zeros(len(CATS)), CATS) == "—"
    assert recognition.best_guess(np.array([0.0, 0.2, 0.1, 0.0]), CATS) == "incubator"
