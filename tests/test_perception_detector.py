"""The trained detector (biovln_ms.perception.segmenter / train_detector / evaluate_detector, `biovln-ms
perception train|evaluate`): instance matching and intervals, a tiny training run on synthetic frames in
the frame dataset's format (deterministic, evaluated), the shipped weights, and one-line errors for a
missing, corrupt or foreign weights file and a frame of the wrong shape."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from PIL import Image
from typer.testing import CliRunner

from biovln_ms.cli import app
from biovln_ms.perception import frames as F
from biovln_ms.perception import segmenter as S
from biovln_ms.perception.detectors import TrainedDetector, drop_floor, make_detector
from biovln_ms.perception.frames import FramesError
from biovln_ms.perception.matching import MISS_CAUSES, Tally, annotated, box_iou, box_of, match_frame, wilson
from biovln_ms.perception.scorers import PerceptionError

runner = CliRunner()
CATS = S.goal_categories()


def _inst(category: str, mask: np.ndarray, score: float = 0.9) -> S.Instance:
    return S.Instance(category, mask, score)


def _ann(instances: np.ndarray, cats: dict[int, str]) -> list[dict]:
    return F.instance_annotations(instances, {k: CATS.index(c) + 1 for k, c in cats.items()})


def test_matching_counts_hits_misses_false_alarms_and_ignores_small_instances():
    inst = np.zeros((240, 320), np.uint16)
    inst[20:80, 20:100] = 1  # big, category 0
    inst[150:200, 200:300] = 2  # big, category 1
    inst[5:9, 300:305] = 3  # 20 pixels < min_pixels (37.5 at 320x240): ignored
    anns = annotated(_ann(inst, {1: CATS[0], 2: CATS[1], 3: CATS[2]}), CATS, inst.shape)
    labels = np.zeros_like(inst, np.uint8)
    for k, c in ((1, 0), (2, 1), (3, 2)):
        labels[inst == k] = c + 1
    hit = np.zeros(inst.shape, bool)
    hit[22:80, 20:100] = True  # IoU 0.97 with instance 1
    wrong_place = np.zeros(inst.shape, bool)
    wrong_place[100:140, 0:60] = True  # overlaps nothing of category 1
    on_small = np.zeros(inst.shape, bool)
    on_small[5:9, 300:305] = True  # matches the ignored instance: neither a hit nor a false alarm
    tally = Tally(CATS)
    match_frame(
        tally,
        [_inst(CATS[0], hit), _inst(CATS[1], wrong_place), _inst(CATS[2], on_small)],
        anns,
        CATS,
        labels,
    )
    s = tally.summary()["categories"]
    assert (s[CATS[0]]["instances"], s[CATS[0]]["matched"], s[CATS[0]]["precision"]) == (1, 1, 1.0)
    assert s[CATS[0]]["mask_iou"] == pytest.approx(58 / 60, abs=1e-3)
    assert (s[CATS[1]]["recall"], s[CATS[1]]["precision"], s[CATS[1]]["detections"]) == (0.0, 0.0, 1)
    assert (s[CATS[2]]["instances"], s[CATS[2]]["detections"]) == (0, 0)
    assert s[CATS[0]]["pixel_iou"] == pytest.approx(58 * 80 / (60 * 80), abs=1e-3)
    # a detection under the IoU threshold is a false alarm and the instance a miss
    tally = Tally(CATS)
    half = np.zeros(inst.shape, bool)
    half[20:80, 20:50] = True  # IoU 0.375
    match_frame(tally, [_inst(CATS[0], half)], anns, CATS, labels)
    row = tally.summary()["categories"][CATS[0]]
    assert (row["matched"], row["detections"], row["recall"]) == (0, 1, 0.0)


def test_each_miss_gets_its_cause():
    """Six annotated instances of CATS[0], each missed one way (and one of CATS[1] found)."""
    inst = np.zeros((240, 320), np.uint16)
    boxes = {1: (0, 40, 0, 40), 2: (0, 40, 42, 82), 3: (60, 100, 0, 40), 4: (60, 100, 60, 100)}
    boxes |= {5: (120, 160, 0, 40), 6: (120, 160, 60, 100), 7: (180, 220, 0, 40), 8: (180, 220, 100, 140)}
    for k, (y0, y1, x0, x1) in boxes.items():
        inst[y0:y1, x0:x1] = k
    anns = annotated(_ann(inst, {**{k: CATS[0] for k in range(1, 8)}, 8: CATS[1]}), CATS, inst.shape)
    labels = np.zeros_like(inst, np.uint8)
    labels[inst > 0] = 1
    labels[inst == 8] = 2

    def box(y0, y1, x0, x1):
        m = np.zeros(inst.shape, bool)
        m[y0:y1, x0:x1] = True
        return m

    preds = [
        _inst(CATS[0], box(0, 40, 0, 82)),  # over instances 1 and 2: merged, both
        _inst(CATS[0], box(50, 110, 0, 60)),  # over instance 3 and beyond: oversized
        _inst(CATS[0], box(60, 70, 60, 100)),  # a quarter of instance 4: partial
        _inst(CATS[1], box(180, 220, 100, 140)),  # instance 8, found
    ]
    net = np.zeros(inst.shape, np.int64)
    net[120:160, 0:40] = 1  # instance 5: labelled right, but no detection kept: dropped
    net[120:160, 60:100] = 3  # instance 6: labelled as CATS[2]
    # instance 7: background
    tally = Tally(CATS, causes=True)
    match_frame(tally, preds, anns, CATS, labels, net)
    row = tally.summary()["categories"][CATS[0]]
    assert row["matched"] == 0 and list(row["misses"]) == [c for c in MISS_CAUSES if row["misses"].get(c)]
    assert row["misses"] == {"merged": 2, "oversized": 1, "partial": 1, "dropped": 1, "other category": 1,
                             "background": 1}  # fmt: skip
    assert row["confused_with"] == {CATS[2]: 1}
    assert tally.summary()["categories"][CATS[1]]["matched"] == 1
    assert "misses" not in Tally(CATS).summary()["categories"][CATS[0]]  # training's validation: none


def test_an_outline_found_as_a_filled_region_matches_by_box_not_by_mask():
    """The pipette stand's case: annotated as its rails (an outline), detected as the region they enclose."""
    inst = np.zeros((240, 320), np.uint16)
    inst[40:140, 100:104] = inst[40:140, 156:160] = inst[40:44, 100:160] = 1  # a frame of 4-pixel rails
    anns = annotated(_ann(inst, {1: CATS[4]}), CATS, inst.shape)
    labels = np.where(inst > 0, 5, 0).astype(np.uint8)
    filled = np.zeros(inst.shape, bool)
    filled[40:140, 100:160] = True  # box IoU 1, mask IoU 0.2
    by_mask, by_box = Tally(CATS), Tally(CATS, rule="box")
    for tally in (by_mask, by_box):
        match_frame(tally, [_inst(CATS[4], filled)], anns, CATS, labels)
    mask_row, box_row = by_mask.summary()["categories"][CATS[4]], by_box.summary()["categories"][CATS[4]]
    assert (mask_row["recall"], mask_row["precision"]) == (0.0, 0.0)
    assert (box_row["recall"], box_row["precision"], box_row["box_iou"]) == (1.0, 1.0, 1.0)
    assert box_iou(box_of(filled), (100, 40, 130, 140)) == pytest.approx(0.5)
    with pytest.raises(ValueError, match="match rule"):
        Tally(CATS, rule="polygon")


def test_wilson_interval():
    lo, hi = wilson(8, 10)
    assert lo == pytest.approx(0.4902, abs=1e-3) and hi == pytest.approx(0.9433, abs=1e-3)
    assert wilson(0, 0) is None


# --- a tiny frame dataset in the part-1 format, drawn without the simulator -------------------------
def _synthetic_frames(root: Path, n: int = 12, size=(160, 120)) -> Path:
    """Frames of a coloured box per category (category k: a fixed colour) on a grey floor."""
    rng = np.random.default_rng(0)
    colours = rng.integers(0, 256, (len(CATS), 3))
    (root / "frames").mkdir(parents=True)
    (root / "annotations").mkdir()
    parts = {p: {"images": [], "annotations": [], "categories": F.coco_categories()} for p in F.PARTS}
    ann_id = 0
    for i in range(n):
        part = F.PARTS[i % 3] if i >= 6 else "train"
        rgb = np.full((size[1], size[0], 3), 120, np.uint8) + rng.integers(
            0, 10, (size[1], size[0], 3)
        ).astype(np.uint8)
        inst = np.zeros((size[1], size[0]), np.uint16)
        cats = {}
        for k in (1, 2):
            c = int(rng.integers(3))  # three categories only: learnable in a few steps
            x0, y0 = int(rng.integers(0, size[0] - 50)), int(rng.integers(0, size[1] - 40))
            rgb[y0 : y0 + 40, x0 : x0 + 50] = colours[c]
            inst[y0 : y0 + 40, x0 : x0 + 50] = k
            cats[k] = CATS[c]
        cats = {k: c for k, c in cats.items() if (inst == k).any()}
        names = {kind: f"frames/{i:06d}.{kind}.png" for kind in ("rgb", "instances")}
        Image.fromarray(rgb).save(root / names["rgb"])
        Image.fromarray(inst).save(root / names["instances"])
        image = {"id": i, "file_name": names["rgb"], "instances_file": names["instances"], "part": part}
        image.update(
            {"group": i // 2, "lighting": "fast", "noise": "ideal", "width": size[0], "height": size[1]}
        )
        parts[part]["images"].append(image)
        for a in _ann(inst, cats):
            ann_id += 1
            parts[part]["annotations"].append({"id": ann_id, "image_id": i, **a})
    for p, coco in parts.items():
        (root / "annotations" / f"{p}.json").write_text(json.dumps(coco))
    manifest = {
        "format_version": F.FORMAT_VERSION,
        "seed": 0,
        "categories": CATS,
        "files": {},
        "source": "synthetic",
        "width": size[0],
        "height": size[1],
    }
    (root / "manifest.json").write_text(json.dumps(manifest))
    return root


@pytest.fixture(scope="module")
def trained(tmp_path_factory) -> tuple[Path, Path]:
    root = tmp_path_factory.mktemp("detector")
    frames = _synthetic_frames(root / "frames")
    r = runner.invoke(
        app,
        [
            "perception",
            "train",
            "-o",
            str(root / "run"),
            "--frame-data",
            str(frames),
            "--epochs",
            "2",
            "--batch",
            "3",
            "--threads",
            "1",
        ],
    )
    assert r.exit_code == 0, r.output
    return frames, root / "run"


@pytest.mark.slow
def test_training_writes_weights_plot_and_log_reproducibly(trained, tmp_path):
    from biovln_ms.perception.train_detector import train_detector

    frames, run = trained
    data = json.loads((run / "train.json").read_text())
    assert data["epochs_run"] == 2 and len(data["loss"]) == 2 * -(-data["train_frames"] // 3)
    assert all(np.isfinite(data["loss"])) and (run / "train.png").stat().st_size > 10_000
    assert data["whole_seconds"] >= data["seconds"] > 0  # the command's time holds the training loop's
    header, net = S.load_net(run / "detector.safetensors")
    assert header["categories"] == CATS and header["seed"] == 0 and header["input_size"] == list(S.INPUT_SIZE)
    assert header["classes"][0] == "background" and header["epochs"] == 2
    # the operating point: the grid's score with the best validation F1, in the header the segmenter reads
    from biovln_ms.perception.train_detector import SCORE_GRID

    points = data["operating_points"]
    assert [p["min_score"] for p in points] == list(SCORE_GRID)
    best = max(p["f1"] for p in points)
    assert data["min_score"] == min(p["min_score"] for p in points if p["f1"] == best)
    assert header["min_score"] == data["min_score"] == S.Segmenter(run / "detector.safetensors").min_score
    again = train_detector(
        frames, tmp_path / "again", seed=0, epochs=2, batch=3, threads=1, commit=header["git_commit"]
    )
    assert again["loss"] == data["loss"]
    assert (tmp_path / "again" / "detector.safetensors").read_bytes() == (
        run / "detector.safetensors"
    ).read_bytes()


@pytest.mark.slow
def test_training_at_another_input_size_is_read_back_from_the_header(trained, tmp_path):
    from biovln_ms.perception.train_detector import train_detector

    frames, _ = trained
    data = train_detector(frames, tmp_path / "r", epochs=1, batch=3, threads=1, input_size=(96, 72))
    seg = S.Segmenter(tmp_path / "r" / "detector.safetensors")
    assert data["input_size"] == seg.header["input_size"] == [96, 72] and seg.input_size == (96, 72)
    lab, conf = seg.labels(np.zeros((240, 320, 3), np.uint8))
    assert lab.shape == conf.shape == (72, 96)
    with pytest.raises(FramesError, match="field 'input_size'.*larger than the frames"):
        train_detector(frames, tmp_path / "big", epochs=1, threads=1, input_size=(640, 480))


@pytest.mark.parametrize("size", ["160x100", "16x12", "axb", "1000000x750000", "800x600", "²x³", "9" * 5000])
def test_a_bad_input_size_is_a_one_line_error(tmp_path, size):
    r = runner.invoke(
        app,
        [
            "perception",
            "train",
            "-o",
            str(tmp_path / "r"),
            "--frame-data",
            str(tmp_path),
            "--input-size",
            size,
        ],
    )
    assert r.exit_code != 0
    text = str(r.exception or "") + r.output
    assert "field 'input_size'" in text and "\n" not in text.strip() and len(text) < 300, text


def _evaluate(frames, run, *extra):
    """``perception evaluate`` of ``run``'s weights on ``frames`` on one thread, with ``extra`` options."""
    weights = ["--weights", str(run / "detector.safetensors"), "--threads", "1"]
    return runner.invoke(app, ["perception", "evaluate", "--frame-data", str(frames), *weights, *extra])


@pytest.mark.slow
def test_evaluate_reports_each_held_out_part(trained, tmp_path):
    frames, run = trained
    out, table = tmp_path / "eval.json", tmp_path / "table.json"
    r = _evaluate(
        frames, run, "--lighting", "fast", "--noise", "ideal", "-o", str(out), "--table", str(table)
    )
    assert r.exit_code == 0, r.output
    result = json.loads(out.read_text())
    parts = result["results"]["fast/ideal"]
    assert set(parts) == {"test_scenes", "test_looks"} and parts["test_scenes"]["frames"] == 2
    box = result["results_box"]["fast/ideal"]["test_scenes"]
    assert box["frames"] == 2 and "box_iou" in next(iter(box["categories"].values()))
    assert sum(row["instances"] for row in parts["test_scenes"]["categories"].values()) > 0
    assert result["detect_ms_640x480"]["median"] > 0
    rows = json.loads(table.read_text())["rows"]
    assert [r[0] for r in rows] == [*CATS, "mean over categories"]
    r = _evaluate(frames, run, "--lighting", "dusk")
    assert r.exit_code != 0 and "unknown lighting 'dusk'" in str(r.exception or r.output)


def test_instances_under_the_operating_point_are_dropped(monkeypatch):
    seg = S.Segmenter()
    w, h = seg.input_size
    lab, conf = np.zeros((h, w), int), np.zeros((h, w))
    lab[10:40, 10:40], conf[10:40, 10:40] = 1, 0.9  # a confident region of the first category
    lab[60:100, 60:100], conf[60:100, 60:100] = 1, 0.3  # and an unsure one
    monkeypatch.setattr(seg, "labels", lambda rgb: (lab, conf))
    frame = np.zeros((h, w, 3), np.uint8)
    seg.min_score = 0.0
    assert sorted(round(i.score, 2) for i in seg.instances(frame)) == [0.3, 0.9]
    seg.min_score = 0.5
    assert [round(i.score, 2) for i in seg.instances(frame)] == [0.9]


def test_bad_weights_and_frames_are_one_line_errors(tmp_path, monkeypatch):
    import torch

    path = tmp_path / "fresh.safetensors"  # an untrained net: the checks are the same for any weights
    torch.manual_seed(0)
    S.save_weights(path, S.build_net(len(CATS) + 1, pretrained=False), S.header_of(CATS, 0, None))
    with pytest.raises(PerceptionError, match="weights file missing.*check the path.*perception train") as e:
        S.Segmenter(tmp_path / "absent.safetensors")
    assert "\n" not in str(e.value) and "reinstall" not in str(e.value)
    gone = tmp_path / "assets" / "detector.safetensors"
    monkeypatch.setattr(S, "shipped_weights", lambda: gone)
    with pytest.raises(PerceptionError, match="missing.*reinstall biovln-ms"):  # the shipped file gone
        S.read_header(gone)
    bad = tmp_path / "bad.safetensors"
    bad.write_bytes(path.read_bytes()[:5000])  # truncated
    with pytest.raises(PerceptionError, match="corrupt|not a safetensors"):
        S.Segmenter(bad)
    bad.write_bytes(b"garbage that is no weights file")
    with pytest.raises(PerceptionError, match="not a safetensors"):
        S.Segmenter(bad)
    pickled = tmp_path / "pickled.pt"  # a pickle (torch.save) is refused, never unpickled
    torch.save({"w": torch.zeros(2)}, pickled)
    with pytest.raises(PerceptionError, match="not a safetensors|no detector header"):
        S.Segmenter(pickled)
    header, net = S.load_net(path)
    for score in ("high", 1.5, None):  # the operating point must be a number in [0, 1]
        odd = tmp_path / "odd_score.safetensors"
        odd.write_bytes(S.weights_bytes(net, {**header, "min_score": score}))
        with pytest.raises(PerceptionError, match="min_score .* not a number in \\[0, 1\\]"):
            S.Segmenter(odd)
    for size in ([0, 0], "ab", [160], [160, 100], [True, 1]):  # the header's input size is checked too
        odd = tmp_path / "odd_size.safetensors"
        odd.write_bytes(S.weights_bytes(net, {**header, "input_size": size}))
        with pytest.raises(PerceptionError, match="odd_size.*field 'input_size'.*perception train") as e:
            S.Segmenter(odd)
        assert "\n" not in str(e.value)
    foreign = tmp_path / "foreign.safetensors"
    other = [*CATS[:-1], "flux_capacitor"]
    foreign.write_bytes(
        S.weights_bytes(net, {**header, "categories": other, "categories_sha256": S.categories_sha256(other)})
    )
    with pytest.raises(PerceptionError, match="another catalog.*flux_capacitor.*perception train"):
        S.Segmenter(foreign)
    det = TrainedDetector(path)
    assert (
        det.name == "trained:fresh.safetensors"
        and make_detector(f"trained:{path}").segmenter.categories == CATS
    )
    k = np.array([[[320.0, 0, 320], [0, 320, 240], [0, 0, 1]]])  # level camera, 1.2 m up, looking along x
    ext = np.array([[[0.0, -1, 0, 0], [0, 0, -1, 1.2], [1, 0, 0, 0]]])
    obs = {
        "sensor_data": {"head": {"rgb": np.full((1, 480, 640, 3), 90, np.uint8)}},
        "sensor_param": {"head": {"intrinsic_cv": k, "extrinsic_cv": ext}},
    }
    obs["sensor_data"]["head"]["depth"] = np.full((1, 480, 640, 1), 2000, np.int16)
    mask = det.detect(obs, CATS[0])
    assert mask.shape == (480, 640) and mask.dtype == bool
    with pytest.raises(PerceptionError, match="no head camera depth.*obs_mode='rgbd'") as e:
        drop_floor(np.ones((480, 640), bool), {"sensor_data": {"head": obs["sensor_data"]["head"]}})
    assert "\n" not in str(e.value)
    no_intrinsics = {**obs, "sensor_param": {"head": {"extrinsic_cv": ext}}}
    with pytest.raises(PerceptionError, match="no head camera depth"):
        drop_floor(np.ones((480, 640), bool), no_intrinsics)
    for frame, fix in (  # each wrong frame gets its own fix
        (np.zeros((480, 480, 3), np.uint8), "4:3 size"),
        (np.zeros((480, 640), np.uint8), "RGB: \\(H, W, 3\\)"),
        (np.zeros((480, 640, 4), np.uint8), "RGB: \\(H, W, 3\\)"),
        (np.zeros((480, 640, 3), np.float32), "uint8 RGB in \\[0, 255\\]"),
    ):
        with pytest.raises(PerceptionError, match=f"field 'rgb'.*width:height.*fix: .*{fix}") as e:
            det.segmenter.target_mask(frame, CATS[0])
        assert "\n" not in str(e.value)
    with pytest.raises(PerceptionError, match="a folder, not a detector weights file.*detector.safetensors"):
        S.Segmenter(tmp_path)
    with pytest.raises(PerceptionError, match="not one of the detector's"):
        det.segmenter.target_mask(np.zeros((120, 160, 3), np.uint8), "flux_capacitor")


def test_frames_of_another_catalog_are_refused(tmp_path):
    from biovln_ms.perception.train_detector import read_manifest

    (tmp_path / "manifest.json").write_text(
        json.dumps({"format_version": F.FORMAT_VERSION, "categories": ["x"]})
    )
    with pytest.raises(F.FramesError, match="another catalog's goal categories"):
        read_manifest(tmp_path)
    with pytest.raises(F.FramesError, match="no manifest.json"):
        read_manifest(tmp_path / "nowhere")


def test_shipped_weights_load_and_are_in_the_assets_manifest():
    from biovln_ms.assetgen.generate import verify_assets
    from biovln_ms.paths import ASSET_DIR

    manifest = json.loads((ASSET_DIR / "manifest.json").read_text())
    assert S.SHIPPED in manifest["weights"] and verify_assets(ASSET_DIR) == []
    assert S.shipped_weights().stat().st_size <= 20 * 2**20
    det = make_detector("trained")
    assert det.segmenter.categories == CATS and det.name == "trained"
    header = det.segmenter.header
    assert header["frozen_blocks"] == S.FROZEN_BLOCKS and header["input_size"] == list(S.INPUT_SIZE)
    # the docs' training log is the shipped weights' own
    log = json.loads((Path(__file__).parents[1] / "docs/data/perception/detector_train.json").read_text())
    assert log["header"] == header
    frame = np.full((480, 640, 3), 90, np.uint8)
    obs = {"sensor_data": {"head": {"rgb": frame[None]}}}
    mask = det.detect(obs, CATS[0])
    assert mask.shape == (480, 640) and mask.dtype == bool
