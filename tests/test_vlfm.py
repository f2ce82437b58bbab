"""VLFM: value-map fusion, the offline scorer, local-directory models, GT detection, a run through the
harness."""

import math
import string
import sys

import numpy as np
import pytest

from biovln_ms.baselines.frontier import OccupancyMap, Scan
from biovln_ms.baselines.frontier.planner import Candidate
from biovln_ms.baselines.policy import TaskSpec
from biovln_ms.eval.harness import EvalConfig, evaluate, load_records
from biovln_ms.perception.detectors import GTSegmentationDetector, make_detector
from biovln_ms.perception.scorers import PerceptionError, make_scorer


class ConstantScorer:
    name = "constant"

    def __init__(self, value: float) -> None:
        self.value = value

    def score(self, rgb, target):
        return self.value


def _policy(value=0.5):
    from biovln_ms.baselines.vlfm import VLFMPolicy

    p = VLFMPolicy(scorer=ConstantScorer(value))
    p.map = OccupancyMap((0.0, 0.0), 0.05, 10.0)
    p.value = np.zeros((p.map.n, p.map.n), np.float32)
    p.confidence = np.zeros_like(p.value)
    p.hfov = math.radians(79)
    return p


def test_value_map_fusion_is_confidence_weighted():
    p = _policy()
    angles = np.linspace(-math.radians(39.5), math.radians(39.5), 81)
    scan = Scan(np.zeros(2), np.stack([np.cos(angles), np.sin(angles)], 1), np.full(81, 2.0))
    p._paint(scan, 0.8)
    axis = p.map.cell([1.0, 0.0])
    edge = p.map.cell([1.0 * math.cos(angles[1]), 1.0 * math.sin(angles[1])])
    assert p.value[axis[0], axis[1]] == pytest.approx(0.8)
    assert p.confidence[axis[0], axis[1]] == pytest.approx(1.0, abs=1e-3)  # on the optical axis
    assert p.confidence[edge[0], edge[1]] < 0.05  # near the edge of the view cone
    p._paint(scan, 0.2)  # same confidence twice: the plain mean; confidence (c^2 + c^2) / 2c = c
    assert p.value[axis[0], axis[1]] == pytest.approx(0.5)
    assert p.confidence[axis[0], axis[1]] == pytest.approx(1.0, abs=1e-3)
    behind = p.map.cell([-1.0, 0.0])
    assert p.confidence[behind[0], behind[1]] == 0.0


def test_frontier_choice_follows_the_value_map():
    p = _policy()
    near, far = Candidate(1.0, np.array([1.0, 0.0]), 20), Candidate(3.0, np.array([0.0, 2.0]), 20)
    assert np.array_equal(p.choose([near, far], None), near.position)  # equal values: the shorter path
    rc = p.map.cell(far.position)
    p.value[rc[0], rc[1]] = 0.9
    assert np.array_equal(p.choose([near, far], None), far.position)


class MaskDetector:
    name = "mask"

    def __init__(self, mask) -> None:
        self.mask = mask

    def detect(self, obs, category):
        return self.mask


def _detect_object(erode_px: int, cluster_eps: float) -> np.ndarray:
    """A 40 x 30 px object 2 m ahead; its mask is 1 px too wide on every side (those pixels read a surface
    0.1 m behind it, close enough to link with it) and also covers a 10 x 10 px patch of another thing
    3.5 m ahead."""
    depth = np.full((120, 160), 5.0)
    depth[39:71, 59:101] = 2.1
    depth[40:70, 60:100] = 2.0
    depth[10:20, 120:130] = 3.5
    mask = np.zeros_like(depth, bool)
    mask[39:71, 59:101] = True
    mask[10:20, 120:130] = True
    intrinsic = np.array([[100.0, 0, 80], [0, 100.0, 60], [0, 0, 1]])
    extrinsic = np.eye(4)
    extrinsic[:3, :3] = [[0, -1, 0], [0, 0, -1], [1, 0, 0]]  # OpenCV camera at the origin, looking along +x
    from biovln_ms.baselines.vlfm import VLFMPolicy

    p = VLFMPolicy(scorer=ConstantScorer(0.5), erode_px=erode_px, cluster_eps=cluster_eps)
    p._detector, p.category, p.object_points, p.detections = MaskDetector(mask), "x", np.zeros((0, 2)), 0
    p._frame = lambda obs: (depth, intrinsic, extrinsic)
    p._detect(None)
    return p.object_points[:, 0]  # distance ahead


def _has(x: np.ndarray, value: float) -> bool:
    return bool(np.any(np.abs(x - value) < 0.01))


def test_object_cloud_drops_mask_edges_and_stray_clusters():
    raw = _detect_object(erode_px=0, cluster_eps=math.inf)  # unfiltered: the rim and the patch get in
    assert _has(raw, 2.1) and _has(raw, 3.5)
    eroded = _detect_object(erode_px=3, cluster_eps=math.inf)  # erosion drops the rim, not the patch
    assert not _has(eroded, 2.1) and _has(eroded, 3.5)
    clustered = _detect_object(erode_px=0, cluster_eps=0.15)  # clustering drops the patch; the rim links
    assert _has(clustered, 2.1) and not _has(clustered, 3.5)
    kept = _detect_object(erode_px=3, cluster_eps=0.15)
    assert len(kept) >= 20 and np.allclose(kept, 2.0)  # only the object's own surface


def test_gt_detector_reads_the_semantic_sensor():
    import torch

    task = TaskSpec(
        forward_step=0.25,
        turn_deg=30.0,
        hfov_deg=79.0,
        max_episode_steps=500,
        goal_categories=("refrigerator", "centrifuge"),
        control_mode="discrete",
        robot_radius=0.2,
    )
    det = make_detector("gt")
    assert isinstance(det, GTSegmentationDetector)
    det.reset(task)
    semantic = np.zeros((120, 160), np.int16)
    semantic[10:30, 10:30] = 2  # 400 centrifuge pixels
    semantic[50:53, 50:53] = 1  # 9 refrigerator pixels: fewer than 150 at 640x480 (9.4 at 160x120)
    obs = {"extra": {"semantic_category": torch.from_numpy(semantic)[None, ..., None]}}
    mask = det.detect(obs, "centrifuge")
    assert mask.shape == (120, 160) and mask.sum() == 400 and mask[10:30, 10:30].all()
    assert not det.detect(obs, "refrigerator").any()
    with pytest.raises(PerceptionError, match="semantic_category"):
        det.detect({"extra": {}}, "centrifuge")


def test_offline_scorer_projects_imagenet_classes_onto_the_target(monkeypatch):
    s = make_scorer("default")
    rgb = np.zeros((120, 160, 3), np.uint8)
    assert 0.0 <= s.score(rgb, "refrigerator") <= 1.0
    onehot = np.zeros(1000)
    onehot[760] = 1.0  # ImageNet class 760: refrigerator
    monkeypatch.setattr(s, "class_probabilities", lambda rgb: onehot)
    assert s.score(rgb, "refrigerator") > s.score(rgb, "centrifuge") + 0.2


def test_clip_scorer_loads_from_a_local_directory(tmp_path):
    import torch
    from transformers import CLIPConfig, CLIPImageProcessorPil, CLIPModel, CLIPProcessor, CLIPTokenizer

    vocab = {"<|startoftext|>": 0, "<|endoftext|>": 1}
    for c in string.ascii_lowercase + ".":
        vocab[c] = len(vocab)
        vocab[c + "</w>"] = len(vocab)
    image_processor = CLIPImageProcessorPil(size={"shortest_edge": 32}, crop_size={"height": 32, "width": 32})
    proc = CLIPProcessor(image_processor=image_processor, tokenizer=CLIPTokenizer(vocab=vocab, merges=[]))
    small = {"hidden_size": 32, "intermediate_size": 64, "num_hidden_layers": 1, "num_attention_heads": 2}
    cfg = CLIPConfig(
        text_config=dict(
            vocab_size=len(vocab),
            max_position_embeddings=77,
            bos_token_id=0,
            eos_token_id=1,
            pad_token_id=1,
            **small,
        ),
        vision_config=dict(image_size=32, patch_size=8, **small),
        projection_dim=16,
    )
    torch.manual_seed(0)
    CLIPModel(cfg).save_pretrained(tmp_path)  # a tiny random CLIP: the loading path, not the accuracy
    proc.save_pretrained(tmp_path)
    s = make_scorer(f"clip:{tmp_path}")
    rgb = (np.random.default_rng(0).random((120, 160, 3)) * 255).astype(np.uint8)
    a, b = s.score(rgb, "refrigerator"), s.score(rgb, "centrifuge")
    assert 0.0 <= a <= 1.0 and 0.0 <= b <= 1.0 and a != b
    with pytest.raises(PerceptionError, match="no config.json"):
        make_scorer(f"clip:{tmp_path / 'missing'}")
    with pytest.raises(PerceptionError, match="unknown scorer"):
        make_scorer("blip2")


@pytest.fixture(scope="module")
def dataset(held_out_dataset):
    return held_out_dataset(ms_val=3)


def test_the_gt_detector_is_its_own_method_not_a_vlfm_option():
    from biovln_ms.baselines.vlfm import VLFMPolicy
    from biovln_ms.errors import BioVLNError
    from biovln_ms.eval.methods import GT_ABLATION, METHODS
    from biovln_ms.perception.detector_specs import GT_OBS

    assert VLFMPolicy().obs_mode == METHODS["vlfm"].obs_mode == "rgb+depth"  # no segmentation sensor
    assert VLFMPolicy(detector="gt").obs_mode == METHODS["vlfm_gt"].obs_mode == "rgb+depth+segmentation"
    assert VLFMPolicy().label == "VLFM (learned detector)"
    gt = GTSegmentationDetector()  # a built detector object tells the same as its spec
    assert VLFMPolicy(detector=gt).obs_mode == "rgb+depth+segmentation"
    assert VLFMPolicy(detector=gt).label == "VLFM (GT detector)"
    for name in ("vlfm", "protocol_vlfm"):
        with pytest.raises(BioVLNError, match="vlfm_gt") as err:
            METHODS[name].preflight(detector="gt")
        assert err.value.field == "detector"
        METHODS[name].preflight(detector="trained")  # the others are its own: the shipped weights read
    assert "detector" not in METHODS["vlfm_gt"].options
    for learned, ablation in GT_ABLATION.items():  # each learned-detector method's GT ablation, registered
        assert METHODS[learned].obs_mode == "rgb+depth" and METHODS[ablation].obs_mode == GT_OBS
        assert METHODS[ablation].env_id == METHODS[learned].env_id


@pytest.mark.parametrize("method", ["vlfm", "protocol_vlfm"])
def test_eval_detector_gt_runs_the_gt_ablation_method(method, monkeypatch, tmp_path):
    from typer.testing import CliRunner

    import biovln_ms.eval.harness as harness
    from biovln_ms.cli import app
    from biovln_ms.eval.methods import GT_ABLATION

    seen = []

    def fake_evaluate(cfg, **_):  # the CLI's hand-over is what is tested, not a run
        seen.append(cfg)
        raise SystemExit(0)

    monkeypatch.setattr(harness, "evaluate", fake_evaluate)
    r = CliRunner().invoke(app, ["eval", "-m", method, "--detector", "gt", "-o", str(tmp_path)])
    assert r.exit_code == 0, r.output
    assert seen[0].method == GT_ABLATION[method] == f"{method}_gt" and "detector" not in seen[0].method_kwargs
    assert f"method {method}_gt" in r.output


@pytest.mark.slow
def test_vlfm_with_either_detector_through_the_harness(dataset, tmp_path):
    """The learned detector (the default) on RGB alone, and the GT ablation, on the same episodes."""
    for method, detector, label in (
        ("vlfm", "trained", "VLFM (learned detector)"),
        ("vlfm_gt", "gt-segmentation", "VLFM (GT detector)"),
    ):
        cfg = EvalConfig(method, "ms_val", str(tmp_path), dataset, workers=1, camera=(320, 240))
        summary = evaluate(cfg, progress=False)
        recs = load_records(tmp_path / method / "ms_val" / "episodes.jsonl")
        assert summary["overall"]["episodes"] == 3 and not any(r.get("error") for r in recs)
        stats = [r["policy_stats"] for r in recs]
        assert all(s["detector"] == detector for s in stats)
        assert all(s["scorer"] == "efficientnet-lite0+minilm" for s in stats)
        assert {s["label"] for s in stats} == {label}
        assert any(s["object_seen"] for s in stats), method  # the target is found in this small room


def test_image_detectors_drop_the_floor_at_an_objects_base():
    """A mask that bleeds past an object's outline onto the floor keeps the object's pixels only."""
    from biovln_ms.constants import FLOOR_HEIGHT
    from biovln_ms.perception.detectors import drop_floor

    h, w, f = 120, 160, 100.0
    k = np.array([[f, 0, w / 2], [0, f, h / 2], [0, 0, 1]])
    # camera 1 m above the floor looking along world x (world z up; OpenCV: x right, y down, z forward)
    r = np.array([[0.0, -1, 0], [0, 0, -1], [1, 0, 0]])
    e = np.hstack([r, -r @ np.array([[0.0], [0], [1]])])
    v = np.arange(h)[:, None].repeat(w, 1).astype(float)
    depth = np.where(v > h / 2, f / np.maximum(v - h / 2, 1e-9), 0.0)  # the floor, below the horizon
    face = np.zeros((h, w), bool)
    face[30:90, 60:100] = True  # an object's face 2 m ahead, from 1.6 m down to 0.42 m above the floor
    depth[face] = 2.0
    obs = {
        "sensor_data": {"head": {"depth": np.round(depth * 1000).astype(np.int16)[None, ..., None]}},
        "sensor_param": {"head": {"intrinsic_cv": k[None], "extrinsic_cv": e[None]}},
    }
    mask = face.copy()
    mask[90:110, 55:105] = True  # a halo that bleeds onto the floor below and beside it
    mask[5, 5] = True  # no depth reading there (above the horizon): kept
    kept = drop_floor(mask, obs)
    heights = 1.0 - (v - h / 2) / f * depth  # each pixel's height above the floor
    assert np.all(heights[90:110, 55:105] < FLOOR_HEIGHT) and np.all(heights[face] > 0.4)
    assert np.array_equal(kept, face | (np.arange(h)[:, None] == 5) & (np.arange(w) == 5))
    assert not drop_floor(np.zeros((h, w), bool), obs).any()


def test_a_run_folder_of_the_gt_detector_is_not_resumed_by_the_learned_one(tmp_path):
    """A ``vlfm`` folder made when the GT detector was VLFM's default (no label in its manifest, its
    records naming their maker) is refused; one of the learned detector resumes."""
    from biovln_ms.errors import BioVLNError
    from biovln_ms.eval.harness import check_resume

    old = {"method": "vlfm", "noise": "ideal", "robot": "biovln_base", "env_id": "BioVLN-OpFace-v0"}
    old["arguments"] = {"method_kwargs": {}}
    recs = [{"policy_stats": {"label": "VLFM (GT detector)"}}]
    cfg = EvalConfig("vlfm", "ms_val", str(tmp_path), env_id="BioVLN-OpFace-v0")
    made_by = r"label 'VLFM \(GT detector\)', not 'VLFM \(learned detector\)'"
    with pytest.raises(BioVLNError, match=made_by):
        check_resume(cfg, old, recs)
    check_resume(cfg, old, [{"policy_stats": {"label": "VLFM (learned detector)"}}])
    check_resume(cfg, old, [])  # nothing to resume: a fresh start
    kwargs = EvalConfig("vlfm", "ms_val", str(tmp_path), env_id="BioVLN-OpFace-v0", method_kwargs={"x": 1})
    with pytest.raises(BioVLNError, match="method options"):
        check_resume(kwargs, {**old, "label": "VLFM (learned detector)"}, recs)


@pytest.mark.parametrize(
    "spec, field, message",
    [
        ("yolo", "detector", "unknown detector 'yolo'"),
        ("trained:{tmp}/none.safetensors", None, "weights file missing"),
        ("trained:{tmp}", "weights", "a folder, not a detector weights file"),
        ("trained:{tmp}/junk.safetensors", None, "not a safetensors weights file"),
        ("owlvit:{tmp}", "detector", "not a saved Hugging Face model"),
    ],
)
def test_a_detector_that_cannot_run_is_refused_before_any_env(
    spec, field, message, tmp_path, monkeypatch, capsys
):
    """eval's preflight reads the weights' header (no torch) or finds the model folder; a bad spec is one
    line naming the field and the fix, before a worker builds an env."""
    from biovln_ms import cli
    from biovln_ms.eval import harness
    from biovln_ms.eval.methods import METHODS
    from biovln_ms.perception.scorers import PerceptionError

    (tmp_path / "junk.safetensors").write_bytes(b"not weights")
    spec = spec.format(tmp=tmp_path)
    with pytest.raises(PerceptionError, match=message) as err:
        METHODS["vlfm"].preflight(detector=spec)
    assert err.value.field == field and err.value.fix
    with pytest.raises(PerceptionError, match="no config.json"):
        METHODS["protocol_vlfm"].preflight(scorer=f"clip:{tmp_path}")
    METHODS["vlfm"].preflight(detector=GTSegmentationDetector(), scorer=object())  # built objects: theirs

    def no_env(*a, **k):
        raise AssertionError("an env was built")

    monkeypatch.setattr(harness, "_evaluate_locked", no_env)
    argv = ["biovln-ms", "eval", "-m", "vlfm", "-s", "ms_val", "--detector", spec, "-o", str(tmp_path)]
    monkeypatch.setattr(sys, "argv", argv)
    with pytest.raises(SystemExit) as exit_:
        cli.main()
    captured = capsys.readouterr()
    out = (captured.out + captured.err).strip()
    assert exit_.value.code == 2 and message in out and len(out.splitlines()) == 1, out
