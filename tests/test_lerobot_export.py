"""`biovln-ms export lerobot`: recordings of `eval --record` as a LeRobotDataset v3.0, checked against the
format's layout without LeRobot (scripts/check_lerobot_export.py loads it with LeRobot itself).

The recordings are written by the real TrajectoryRecorder from synthetic observations (a smooth image and a
depth ramp per step), so no simulator runs. ``check_v30`` is the format as LeRobot 0.4 reads it: info.json's
features, shapes, fps and path templates; the data parquet's columns and types; contiguous ``index`` and
per-episode ``frame_index`` / ``timestamp``; the episodes' index ranges and file pointers; video frame
counts, sizes and per-episode time ranges; tasks; stats' keys and shapes.
"""

from __future__ import annotations

import base64
import gzip
import json
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

pa = pytest.importorskip("pyarrow")
pq = pytest.importorskip("pyarrow.parquet")

from biovln_ms.bridges import lerobot as lr  # noqa: E402
from biovln_ms.bridges.lerobot import LeRobotExportError, export_lerobot  # noqa: E402
from biovln_ms.cli import app, user_error_line  # noqa: E402
from biovln_ms.learning import recordings  # noqa: E402
from biovln_ms.learning.recorder import TrajectoryRecorder, read_recordings  # noqa: E402
from biovln_ms.learning.recordings import RecordingReadError  # noqa: E402

FPS = 5
STATS = {"min", "max", "mean", "std", "count", "q01", "q10", "q50", "q90", "q99"}


def _frame(t: int, e: int, w: int = 64, h: int = 48) -> np.ndarray:
    """A smooth RGB image that changes with the step (H.264 keeps it close)."""
    y, x = np.mgrid[0:h, 0:w]
    img = np.stack([(x * 4 + 20 * t) % 256, (y * 5 + 40 * e) % 256, np.full_like(x, 128 + 10 * t)], -1)
    return img.astype(np.uint8)


def record(root: Path, lengths=(4, 7, 5), mode="full", scene="lab_s150_v0", size=(64, 48), depth=True):
    """A recording folder as `eval --record` writes it: one worker file, one entry per episode (``depth``:
    whether the camera has a depth sensor)."""
    import torch

    rec = TrajectoryRecorder(root, mode=mode, image_size=None, depth_size=(16, 12))
    for e, n in enumerate(lengths):
        ep = {
            "scene_id": scene,
            "episode_id": str(e),
            "object_category": ("centrifuge", "biosafety_cabinet")[e % 2],
            "object_id": f"inst_{e}",
            "info": {"difficulty": "easy"},
        }
        goal = np.array([3.0, 1.0 + e])
        rec.start(ep, goal)
        for t in range(n):
            h, w = size[1], size[0]
            depth_mm = (500 + 100 * t + 10 * np.arange(h * w).reshape(1, h, w, 1)).astype(np.int16)
            cam = {"rgb": torch.from_numpy(_frame(t, e, w, h)[None])}
            if depth:
                cam["depth"] = torch.from_numpy(depth_mm)
            obs = {"sensor_data": {"head": cam}}
            pose = (0.25 * t, 0.5, 0.1 * t)
            action = 0 if t == n - 1 else 1 + t % 3
            rec.step(t, action, pose, goal, float(np.hypot(*(goal - pose[:2]))), obs)
        rec.finish(success=e != 1)
    return rec.path


def parquet_rows(path: Path) -> list[dict]:
    return pq.read_table(path).to_pylist()


def check_v30(root: Path, fps: int = FPS) -> dict:
    """The dataset at ``root`` against LeRobot's v3.0 layout; returns info.json."""
    import imageio_ffmpeg

    info = json.loads((root / "meta" / "info.json").read_text())
    assert info["codebase_version"] == "v3.0" and info["fps"] == fps
    assert info["data_path"] == "data/chunk-{chunk_index:03d}/file-{file_index:03d}.parquet"
    feats = info["features"]
    for key, dtype in (("timestamp", "float32"), ("frame_index", "int64"), ("episode_index", "int64"),
                       ("index", "int64"), ("task_index", "int64")):  # fmt: skip
        assert feats[key] == {"dtype": dtype, "shape": [1], "names": None}
    for key, ft in feats.items():
        assert ft["dtype"] in ("video", "float32", "int64", "bool"), key
        axes = ft["shape"][0] if len(ft["shape"]) == 1 else len(ft["shape"])  # element names, or axis names
        assert ft["names"] is None or len(ft["names"]) == axes, key
    videos = [k for k, ft in feats.items() if ft["dtype"] == "video"]
    assert info["video_path"] == ("videos/{video_key}/chunk-{chunk_index:03d}/file-{file_index:03d}.mp4"
                                  if videos else None)  # fmt: skip

    # data: the non-video features as columns, of the types LeRobot's datasets.Features cast from
    data_files = sorted((root / "data").glob("chunk-*/file-*.parquet"))
    rows = [r for p in data_files for r in parquet_rows(p)]
    schema = pq.read_schema(data_files[0])
    assert set(schema.names) == {k for k, ft in feats.items() if ft["dtype"] != "video"}
    for key in schema.names:
        shape, t = feats[key]["shape"], schema.field(key).type
        if shape == [1]:
            assert not pa.types.is_list(t) and not pa.types.is_fixed_size_list(t), key
        elif len(shape) == 1:
            assert t.list_size == shape[0], key
        else:
            assert len(rows[0][key]) == shape[0] and len(rows[0][key][0]) == shape[1], key
    assert len(rows) == info["total_frames"]
    assert [r["index"] for r in rows] == list(range(len(rows)))

    # episodes: index ranges, lengths, file pointers, video time ranges
    ep_files = sorted((root / "meta" / "episodes").glob("chunk-*/file-*.parquet"))
    episodes = [r for p in ep_files for r in parquet_rows(p)]
    assert [e["episode_index"] for e in episodes] == list(range(info["total_episodes"]))
    assert info["splits"] == {"train": f"0:{info['total_episodes']}"}
    tasks = pq.read_table(root / "meta" / "tasks.parquet")
    assert json.loads(tasks.schema.metadata[b"pandas"])["index_columns"] == ["__index_level_0__"]
    task_of = dict(zip(tasks.column("task_index").to_pylist(), tasks.column("__index_level_0__").to_pylist()))
    assert len(task_of) == info["total_tasks"] and sorted(task_of) == list(range(len(task_of)))
    video_frames: dict[str, int] = {}
    start = 0
    for e in episodes:
        assert e["dataset_from_index"] == start and e["dataset_to_index"] == start + e["length"]
        start = e["dataset_to_index"]
        data_file = root / info["data_path"].format(
            chunk_index=e["data/chunk_index"], file_index=e["data/file_index"]
        )
        mine = [r for r in parquet_rows(data_file) if r["episode_index"] == e["episode_index"]]
        assert [r["index"] for r in mine] == list(range(e["dataset_from_index"], e["dataset_to_index"]))
        assert [r["frame_index"] for r in mine] == list(range(e["length"]))
        assert np.allclose([r["timestamp"] for r in mine], np.arange(e["length"]) / fps, atol=1e-6)
        assert [r["next.done"] for r in mine] == [False] * (e["length"] - 1) + [True]
        assert {task_of[r["task_index"]] for r in mine} == set(e["tasks"])
        for key in videos:
            path = info["video_path"].format(
                video_key=key,
                chunk_index=e[f"videos/{key}/chunk_index"],
                file_index=e[f"videos/{key}/file_index"],
            )
            before = video_frames.get(path, 0)
            assert e[f"videos/{key}/from_timestamp"] == pytest.approx(before / fps)
            assert e[f"videos/{key}/to_timestamp"] == pytest.approx((before + e["length"]) / fps)
            video_frames[path] = before + e["length"]
        for key in feats:
            assert STATS <= {c.split("/")[-1] for c in e if c.startswith(f"stats/{key}/")}, key
        assert e["meta/episodes/chunk_index"] == 0 and e["meta/episodes/file_index"] == 0
    assert start == info["total_frames"]

    # videos: every frame there, of the feature's size and rate
    for rel, n in video_frames.items():
        reader = imageio_ffmpeg.read_frames(str(root / rel))
        try:
            meta = reader.__next__()
            key = rel.split("/")[1]
            h, w, _ = feats[key]["shape"]
            assert tuple(meta["size"]) == (w, h) and meta["fps"] == fps
            assert sum(1 for _ in reader) == n, rel
        finally:
            reader.close()
    assert len(list((root / "videos").rglob("*.mp4"))) if videos else True

    # stats: every feature, LeRobot's keys and shapes, counted over every frame
    stats = json.loads((root / "meta" / "stats.json").read_text())
    assert set(stats) == set(feats)
    for key, s in stats.items():
        assert set(s) == STATS, key
        want = [3, 1, 1] if feats[key]["dtype"] == "video" else feats[key]["shape"]
        assert list(np.shape(s["mean"])) == want and s["count"] == [info["total_frames"]], key
    return info


@pytest.fixture
def recording(tmp_path: Path) -> Path:
    record(tmp_path / "rec")
    return tmp_path / "rec"


def test_export_is_a_v30_dataset_of_the_recording(recording: Path, tmp_path: Path) -> None:
    r = CliRunner().invoke(app, ["export", "lerobot", str(recording), "-o", str(tmp_path / "lr")])
    assert r.exit_code == 0, r.output
    assert "3 episodes, 16 frames" in r.output
    info = check_v30(tmp_path / "lr")
    assert info["features"][lr.CAMERA_KEY]["shape"] == [48, 64, 3]
    assert info["features"][lr.DEPTH_KEY]["shape"] == [12, 16]

    (entry_file,) = recording.glob("trajectories-*.jsonl.gz")
    entries = list(read_recordings(entry_file))
    rows = parquet_rows(tmp_path / "lr" / "data" / "chunk-000" / "file-000.parquet")
    for e, entry in enumerate(entries):
        mine = [r for r in rows if r["episode_index"] == e]
        for r, step in zip(mine, entry["steps"], strict=True):
            assert r["action"] == step["action"]
            assert r["observation.state"] == pytest.approx(
                [*step["obs"]["position"][:2], *step["obs"]["heading"]], abs=1e-6
            )
            assert r["observation.goal_position"] == pytest.approx(step["obs"]["goal_position"], abs=1e-6)
            depth = np.frombuffer(base64.b64decode(step["obs"]["depth"]), np.float16).reshape(12, 16)
            assert np.array_equal(np.array(r["observation.depth"], np.float32), depth.astype(np.float32))
        assert [r["next.success"] for r in mine] == [False] * (len(mine) - 1) + [entry["success"]]

    # the video holds the recorded frames, H.264-close
    import imageio_ffmpeg

    reader = imageio_ffmpeg.read_frames(
        str(tmp_path / "lr" / "videos" / lr.CAMERA_KEY / "chunk-000" / "file-000.mp4")
    )
    try:
        reader.__next__()
        decoded = [np.frombuffer(f, np.uint8).reshape(48, 64, 3) for f in reader]
    finally:
        reader.close()
    recorded = [_frame(t, e) for e, n in enumerate((4, 7, 5)) for t in range(n)]
    assert len(decoded) == len(recorded)
    assert max(np.abs(d.astype(int) - r).mean() for d, r in zip(decoded, recorded)) < 6

    # stats are those of the data
    stats = json.loads((tmp_path / "lr" / "meta" / "stats.json").read_text())
    state = np.array([r["observation.state"] for r in rows])
    assert stats["observation.state"]["mean"] == pytest.approx(state.mean(0), abs=1e-6)
    assert stats["observation.state"]["std"] == pytest.approx(state.std(0), abs=1e-6)
    assert stats["action"]["max"] == [3.0] and stats["next.done"]["mean"] == pytest.approx([3 / 16])


def test_same_recording_same_bytes(recording: Path, tmp_path: Path) -> None:
    a, b = tmp_path / "a", tmp_path / "b"
    export_lerobot(recording, a)
    export_lerobot(recording, b)
    files = sorted(p.relative_to(a) for p in a.rglob("*") if p.is_file())
    assert files == sorted(p.relative_to(b) for p in b.rglob("*") if p.is_file())
    assert all((a / f).read_bytes() == (b / f).read_bytes() for f in files)


def test_recording_read_in_small_steps(recording: Path, tmp_path: Path, monkeypatch) -> None:
    """Members read a few bytes at a time (and decompressed a few bytes at a time) give the same dataset."""
    export_lerobot(recording, tmp_path / "a")
    monkeypatch.setattr(recordings, "_READ_CHUNK", 7)
    export_lerobot(recording, tmp_path / "b")
    for f in (p for p in (tmp_path / "a").rglob("*") if p.is_file()):
        assert f.read_bytes() == (tmp_path / "b" / f.relative_to(tmp_path / "a")).read_bytes(), f


def test_episodes_are_ordered_and_files_roll_over(tmp_path: Path, monkeypatch) -> None:
    """Several worker files give one fixed episode order; more frames than a file holds start a new data
    and video file, each episode's video time counted from its own file's start."""
    record(tmp_path / "rec", lengths=(3, 4), scene="lab_s151_v0")
    record(tmp_path / "rec2", lengths=(5, 2, 6), scene="lab_s150_v0")
    (src,) = (tmp_path / "rec2").glob("trajectories-*.jsonl.gz")
    src.rename(tmp_path / "rec" / "trajectories-0.jsonl.gz")  # a second worker's file
    for png in (tmp_path / "rec2" / "images").iterdir():
        png.rename(tmp_path / "rec" / "images" / png.name)
    monkeypatch.setattr(lr, "FRAMES_PER_FILE", 8)
    export_lerobot(tmp_path / "rec", tmp_path / "lr", fps=10)
    info = check_v30(tmp_path / "lr", fps=10)
    episodes = parquet_rows(tmp_path / "lr" / "meta" / "episodes" / "chunk-000" / "file-000.parquet")
    order = [(e["biovln/scene_id"], e["biovln/episode_id"]) for e in episodes]
    assert order == [("lab_s150_v0", k) for k in "012"] + [("lab_s151_v0", k) for k in "01"]
    assert [e["data/file_index"] for e in episodes] == [0, 0, 1, 2, 2]
    assert info["total_frames"] == 20 and len(list((tmp_path / "lr" / "videos").rglob("*.mp4"))) == 3


def test_trace_recording_exports_without_cameras(tmp_path: Path) -> None:
    record(tmp_path / "rec", mode="trace")
    info = export_lerobot(tmp_path / "rec", tmp_path / "lr")
    assert lr.CAMERA_KEY not in info["features"] and lr.DEPTH_KEY not in info["features"]
    check_v30(tmp_path / "lr")
    assert not (tmp_path / "lr" / "videos").exists()


def test_rgb_only_recording_exports_without_depth(tmp_path: Path) -> None:
    record(tmp_path / "rec", depth=False)
    info = export_lerobot(tmp_path / "rec", tmp_path / "lr")
    assert lr.CAMERA_KEY in info["features"] and lr.DEPTH_KEY not in info["features"]
    check_v30(tmp_path / "lr")


def test_truncated_last_episode_is_left_out(recording: Path, tmp_path: Path) -> None:
    (path,) = recording.glob("trajectories-*.jsonl.gz")
    path.write_bytes(path.read_bytes()[:-10])  # a run killed while writing its last episode
    info = export_lerobot(recording, tmp_path / "lr")
    assert info["total_episodes"] == 2


def _rewrite(path: Path, edit) -> None:
    entries = list(read_recordings(path))
    edit(entries)
    path.write_bytes(b"".join(gzip.compress((json.dumps(e) + "\n").encode(), mtime=0) for e in entries))


def _set(field, value):
    def edit(entries):
        *parents, last = field
        node = entries[1]
        for p in parents:
            node = node[p]
        node[last] = value

    return edit


@pytest.mark.parametrize(
    ("damage", "words"),
    [
        ("missing", ["recording folder is missing"]),
        ("empty", ["no trajectories-*.jsonl.gz"]),
        ("not_gzip", ["gzip member at byte 0 is corrupt"]),
        ("empty_file", ["holds no complete episode"]),
        ("corrupt_member", ["is corrupt"]),
        ("too_big", ["entry 0 decompresses to more than"]),
        ("not_json", ["not JSON"]),
        ("bad_action", ["entry 1: steps[2].action", "less than or equal to 3"]),
        ("bad_step_idx", ["steps[1].step_idx", "expected 1"]),
        ("bad_depth", ["steps[0].obs.depth", "not float16 12 x 16"]),
        ("frame_missing", ["steps[0].obs.rgb_path", "is missing"]),
        ("frame_outside", ["steps[0].obs.rgb_path", "leads outside"]),
        ("twice", ["recorded twice"]),
        ("out_exists", ["output folder exists"]),
    ],
)
def test_bad_input_is_one_line(recording: Path, tmp_path: Path, damage: str, words: list[str]) -> None:
    (path,) = recording.glob("trajectories-*.jsonl.gz")
    src, out = recording, tmp_path / "lr"
    if damage == "missing":
        src = tmp_path / "nowhere"
    elif damage == "empty":
        src = tmp_path / "empty"
        src.mkdir()
    elif damage == "not_gzip":
        path.write_bytes(b"this is not a recording")
    elif damage == "empty_file":
        path.write_bytes(b"")
    elif damage == "corrupt_member":
        raw = bytearray(path.read_bytes())
        raw[40:60] = bytes(20)  # inside the first member's deflate stream
        path.write_bytes(bytes(raw))
    elif damage == "too_big":
        recordings.MAX_ENTRY_BYTES = 1000  # restored below
    elif damage == "not_json":
        path.write_bytes(gzip.compress(b"{oops\n"))
    elif damage == "bad_action":
        _rewrite(path, lambda es: es[1]["steps"][2].__setitem__("action", 7))
    elif damage == "bad_step_idx":
        _rewrite(path, lambda es: es[1]["steps"][1].__setitem__("step_idx", 5))
    elif damage == "bad_depth":
        _rewrite(
            path, lambda es: es[1]["steps"][0]["obs"].__setitem__("depth", base64.b64encode(b"xx").decode())
        )
    elif damage == "frame_missing":
        (recording / next(read_recordings(path))["steps"][0]["obs"]["rgb_path"]).unlink()
    elif damage == "frame_outside":
        _rewrite(path, lambda es: es[1]["steps"][0]["obs"].__setitem__("rgb_path", "../../etc/passwd"))
    elif damage == "twice":
        (recording / "trajectories-1.jsonl.gz").write_bytes(path.read_bytes())
    elif damage == "out_exists":
        out.mkdir()
    limit = 256 * 2**20
    try:
        with pytest.raises((RecordingReadError, LeRobotExportError)) as exc:
            export_lerobot(src, out)
    finally:
        recordings.MAX_ENTRY_BYTES = limit
    line = user_error_line(exc.value)
    assert "\n" not in line and all(w in line for w in words), line
    assert not any(p.name.startswith(".lr.partial") for p in tmp_path.iterdir())  # nothing half-written
    assert damage == "out_exists" or not out.exists()


def test_failed_export_leaves_no_folder(recording: Path, tmp_path: Path, monkeypatch) -> None:
    """An error after files were written (here the video encoder) removes the partial folder."""
    monkeypatch.setattr(lr, "VIDEO_CODEC", ["-c:v", "no-such-codec"])
    with pytest.raises(LeRobotExportError, match="ffmpeg could not encode"):
        export_lerobot(recording, tmp_path / "lr")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["rec"]


@pytest.mark.slow
@pytest.mark.render
def test_an_evaluation_recording_exports(held_out_dataset, tmp_path: Path) -> None:
    """What `eval --record` writes from the simulator (the recorder's real frames and depth) exports, and
    the export's frames are the recorded ones."""
    from biovln_ms.eval.harness import EvalConfig, evaluate

    rec = tmp_path / "rec"
    cfg = EvalConfig("oracle", "ms_val", str(tmp_path / "res"), held_out_dataset(ms_val=2), workers=1,
                     camera=(160, 120), record_dir=str(rec), record_mode="full")  # fmt: skip
    evaluate(cfg, progress=False)
    info = export_lerobot(rec, tmp_path / "lr")
    check_v30(tmp_path / "lr")
    assert info["total_episodes"] == 2
    assert info["features"][lr.CAMERA_KEY]["shape"] == [224, 224, 3]
    assert info["features"][lr.DEPTH_KEY]["shape"] == [60, 80]
    rows = parquet_rows(tmp_path / "lr" / "data" / "chunk-000" / "file-000.parquet")
    depth = np.array([r["observation.depth"] for r in rows])
    assert np.isfinite(depth).all() and depth.max() > 0.1  # metres, not millimetres
