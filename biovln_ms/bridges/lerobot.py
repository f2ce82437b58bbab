"""LeRobot bridge: recordings of ``eval --record`` as a LeRobotDataset v3.0 (``biovln-ms export lerobot``).

The input is a TrajectoryRecorder folder (``trajectories-<pid>.jsonl.gz`` and, in full mode, ``images/``);
the output is LeRobot's current on-disk format, written the way its own recorder lays it out::

    meta/info.json                                  codebase_version v3.0, fps, features, paths
    meta/stats.json                                 min/max/mean/std/count/q01..q99 of every feature
    meta/tasks.parquet                              task text (the index) -> task_index
    meta/episodes/chunk-000/file-000.parquet        one row per episode: length, file indices, stats
    data/chunk-000/file-000.parquet                 one row per step
    videos/observation.images.head/chunk-000/file-000.mp4

Frame t holds what the policy saw (pose, goal, RGB, depth) and the action it then chose, as the recorder
stores them. ``action`` is the discrete id (0 STOP, 1 FORWARD, 2 LEFT, 3 RIGHT); ``observation.state`` is
[x, y, cos yaw, sin yaw] in the Z-up world frame (metres); ``next.done`` is set on each episode's last frame
and ``next.success`` there too when the episode succeeded (the task definition judges success at STOP).
Several episodes share a data file and a video file (at most ``FRAMES_PER_FILE`` frames each), each at its
own ``from_timestamp``. RGB is H.264 (yuv420p, a keyframe every 2 frames, one encoder thread, bit-exact
container flags: the same recording gives the same bytes with the same ffmpeg). Depth is not a video:
LeRobot decodes video to 8 bits, so ``observation.depth`` is a float32 [H, W] array in metres in the
parquet, the recorder's float16 values unchanged (a camera without depth: no such feature). A trace-mode
recording has no images: its export has neither feature. Statistics have LeRobot's keys and shapes: per
channel in [0, 1] for video, per element otherwise; exact per episode, combined over the dataset by frame
count (quantiles count-weighted, as LeRobot aggregates them).
"""

from __future__ import annotations

import json
import math
import os
import re
import shutil
import subprocess
from pathlib import Path
from typing import Iterator

import numpy as np

from biovln_ms.errors import BioVLNError
from biovln_ms.io_utils import atomic_write_text
from biovln_ms.learning.recordings import Episode, depth_frame, read_episodes, rgb_frame

CODEBASE_VERSION = "v3.0"
CAMERA_KEY = "observation.images.head"
DEPTH_KEY = "observation.depth"
#: frames of one data parquet and one video file (keeps both under LeRobot's 100 / 200 MB defaults)
FRAMES_PER_FILE = 4_000
#: files per chunk folder, LeRobot's default
CHUNKS_SIZE = 1_000
#: bytes of episode rows (mostly their statistics) per meta/episodes file, LeRobot's 100 MB default
EPISODE_META_BYTES = 100 * 2**20
QUANTILES = (0.01, 0.10, 0.50, 0.90, 0.99)
#: the H.264 settings; LeRobot's own recorder uses g=2 too (fast random access when decoding one frame)
VIDEO_CODEC = ["-c:v", "libx264", "-preset", "medium", "-crf", "23", "-g", "2", "-pix_fmt", "yuv420p"]
MAX_FPS = 1_000
#: a frame's side in pixels (the env's largest camera)
MAX_FRAME_SIDE = 4_096


class LeRobotExportError(BioVLNError):
    """An output that is in the way, frames too large, or an encoder that fails."""


# --- statistics (LeRobot's keys and shapes) ---------------------------------------------------------


def _stats(values: np.ndarray, axis) -> dict[str, np.ndarray]:
    """min, max, mean, std, count and quantiles of ``values`` over ``axis`` (float64)."""
    v = values.astype(np.float64)
    out = {
        "min": v.min(axis=axis),
        "max": v.max(axis=axis),
        "mean": v.mean(axis=axis),
        "std": v.std(axis=axis),
        "count": np.array([len(values)]),
    }
    for q, val in zip(QUANTILES, np.quantile(v, QUANTILES, axis=axis)):
        out[f"q{round(q * 100):02d}"] = val
    return out


def _histogram_stats(hist: np.ndarray) -> dict[str, np.ndarray]:
    """``_stats`` of integer values 0..255 given by their counts (exact, without a float copy of every
    pixel; quantiles interpolated as ``np.quantile``'s default)."""
    n = int(hist.sum())
    values = np.arange(len(hist), dtype=np.float64)
    mean = float(values @ hist) / n
    cum = np.cumsum(hist)
    out = {
        "min": float(values[hist > 0][0]),
        "max": float(values[hist > 0][-1]),
        "mean": mean,
        "std": math.sqrt(float(((values - mean) ** 2) @ hist) / n),
    }
    for q in QUANTILES:
        pos = q * (n - 1)
        lo, hi = (int(np.searchsorted(cum, math.floor(p) + 1)) for p in (pos, math.ceil(pos)))
        out[f"q{round(q * 100):02d}"] = lo + (hi - lo) * (pos - math.floor(pos))
    return out


def _episode_stats(columns: dict[str, np.ndarray], frames: np.ndarray | None) -> dict[str, dict]:
    """Statistics of one episode: per element for the parquet columns (a scalar's have shape (1,)), per
    channel in [0, 1] with shape (3, 1, 1) for the video, as LeRobot's ``compute_episode_stats``."""
    stats = {}
    for key, col in columns.items():
        stats[key] = _stats(col if col.ndim > 1 else col[:, None], 0)
    if frames is not None:
        per_channel = [_histogram_stats(np.bincount(frames[..., c].ravel(), minlength=256)) for c in range(3)]
        stats[CAMERA_KEY] = {
            s: np.array([ch[s] / 255.0 for ch in per_channel]).reshape(3, 1, 1) for s in per_channel[0]
        }
        stats[CAMERA_KEY]["count"] = np.array([len(frames)])
    return stats


def _combine(per_episode: list[dict[str, dict]]) -> dict[str, dict]:
    """Dataset statistics from episode statistics, weighted by frame count (LeRobot's aggregation)."""
    out = {}
    for key in per_episode[0]:
        parts = [s[key] for s in per_episode]
        counts = np.array([p["count"][0] for p in parts], np.float64)
        total = counts.sum()

        def weighted(values, counts=counts, total=total):
            arr = np.stack(values)
            return np.tensordot(counts, arr, axes=1) / total

        mean = weighted([p["mean"] for p in parts])
        var = weighted([p["std"] ** 2 + (p["mean"] - mean) ** 2 for p in parts])
        agg = {
            "min": np.min(np.stack([p["min"] for p in parts]), axis=0),
            "max": np.max(np.stack([p["max"] for p in parts]), axis=0),
            "mean": mean,
            "std": np.sqrt(var),
            "count": np.array([int(total)]),
        }
        for q in (k for k in parts[0] if re.fullmatch(r"q\d\d", k)):
            agg[q] = weighted([p[q] for p in parts])
        out[key] = agg
    return out


def _jsonable(stats: dict[str, dict]) -> dict:
    return {k: {s: np.asarray(v).tolist() for s, v in d.items()} for k, d in sorted(stats.items())}


# --- the dataset ------------------------------------------------------------------------------------


def _features(fps: int, image_hw: tuple[int, int] | None, depth_hw: tuple[int, int] | None) -> dict:
    f: dict[str, dict] = {}
    if image_hw is not None:
        h, w = image_hw
        f[CAMERA_KEY] = {
            "dtype": "video",
            "shape": [h, w, 3],
            "names": ["height", "width", "channels"],
            "info": {
                "video.height": h,
                "video.width": w,
                "video.codec": "h264",
                "video.pix_fmt": "yuv420p",
                "video.is_depth_map": False,
                "video.fps": fps,
                "video.channels": 3,
                "has_audio": False,
            },
        }
    if depth_hw is not None:
        f[DEPTH_KEY] = {"dtype": "float32", "shape": list(depth_hw), "names": ["height", "width"]}
    f["observation.state"] = {"dtype": "float32", "shape": [4], "names": ["x", "y", "cos_yaw", "sin_yaw"]}
    f["observation.goal_position"] = {"dtype": "float32", "shape": [2], "names": ["x", "y"]}
    f["observation.dist_to_goal"] = {"dtype": "float32", "shape": [1], "names": ["metres"]}
    f["action"] = {"dtype": "int64", "shape": [1], "names": ["stop0_forward1_left2_right3"]}
    f["next.done"] = {"dtype": "bool", "shape": [1], "names": None}
    f["next.success"] = {"dtype": "bool", "shape": [1], "names": None}
    for key, dtype in (
        ("timestamp", "float32"),
        ("frame_index", "int64"),
        ("episode_index", "int64"),
        ("index", "int64"),
        ("task_index", "int64"),
    ):
        f[key] = {"dtype": dtype, "shape": [1], "names": None}
    return f


def _arrow_type(pa, ft: dict):
    """The parquet column type LeRobot's ``get_hf_features_from_features`` reads ``ft`` as."""
    base = {"float32": pa.float32(), "int64": pa.int64(), "bool": pa.bool_()}[ft["dtype"]]
    shape = ft["shape"]
    if shape == [1]:
        return base
    if len(shape) == 1:
        return pa.list_(base, shape[0])
    return pa.list_(pa.list_(base, shape[1]))  # datasets' Array2D storage: rows of fixed width


def _file_path(template: str, k: int, **kw) -> str:
    return template.format(chunk_index=k // CHUNKS_SIZE, file_index=k % CHUNKS_SIZE, **kw)


DATA_PATH = "data/chunk-{chunk_index:03d}/file-{file_index:03d}.parquet"
VIDEO_PATH = "videos/{video_key}/chunk-{chunk_index:03d}/file-{file_index:03d}.mp4"
EPISODES_PATH = "meta/episodes/chunk-{chunk_index:03d}/file-{file_index:03d}.parquet"


def _groups(episodes: list[Episode]) -> Iterator[list[int]]:
    """Consecutive episodes sharing one data / video file, at most ``FRAMES_PER_FILE`` frames (an
    episode longer than that gets a file of its own)."""
    group, n = [], 0
    for k, ep in enumerate(episodes):
        length = len(ep.entry.steps)
        if group and n + length > FRAMES_PER_FILE:
            yield group
            group, n = [], 0
        group.append(k)
        n += length
    if group:
        yield group


class _Encoder:
    """ffmpeg (imageio-ffmpeg's binary) encoding raw RGB frames from a pipe into one MP4."""

    def __init__(self, path: Path, hw: tuple[int, int], fps: int) -> None:
        import imageio_ffmpeg

        h, w = hw
        cmd = [
            imageio_ffmpeg.get_ffmpeg_exe(), "-hide_banner", "-loglevel", "error", "-nostdin",
            "-f", "rawvideo", "-pix_fmt", "rgb24", "-s", f"{w}x{h}", "-r", str(fps), "-i", "pipe:0",
            "-an", *VIDEO_CODEC, "-threads", "1", "-map_metadata", "-1",
            "-fflags", "+bitexact", "-flags:v", "+bitexact", "-movflags", "+faststart", str(path),
        ]  # fmt: skip
        path.parent.mkdir(parents=True, exist_ok=True)
        self.proc = subprocess.Popen(cmd, stdin=subprocess.PIPE, stderr=subprocess.PIPE)
        self.path = path

    def write(self, frame: np.ndarray) -> None:
        try:
            self.proc.stdin.write(np.ascontiguousarray(frame).tobytes())
        except BrokenPipeError:
            self.close()

    def abort(self) -> None:
        """Stop ffmpeg without waiting for the file (the export failed; the folder goes)."""
        if self.proc.poll() is None:
            self.proc.kill()
        self.proc.wait()
        for pipe in (self.proc.stdin, self.proc.stderr):
            try:
                pipe.close()
            except BrokenPipeError:
                pass

    def close(self) -> None:
        if self.proc.stdin and not self.proc.stdin.closed:
            try:
                self.proc.stdin.close()
            except BrokenPipeError:
                pass
        err = self.proc.stderr.read().decode(errors="replace")
        self.proc.stderr.close()
        if self.proc.wait() != 0:
            raise LeRobotExportError(
                f"ffmpeg could not encode the video ({' '.join(err.split())[:200]})", source=str(self.path)
            )


def export_lerobot(recording: str | Path, out: str | Path, fps: int = 5) -> dict:
    """Write the episodes of a recording folder as a LeRobotDataset v3.0 at ``out`` (which must not
    exist); the folder appears whole or not at all. Returns ``meta/info.json``'s content."""
    try:
        import pyarrow  # noqa: F401
    except ImportError:
        raise LeRobotExportError(
            "the LeRobot export writes parquet with pyarrow, which is not installed",
            fix="pip install 'biovln-ms[lerobot]' (or pip install pyarrow)",
        ) from None
    out = Path(out)
    if not 1 <= fps <= MAX_FPS:
        raise LeRobotExportError(f"fps {fps} is out of range", field="--fps", fix=f"use 1 to {MAX_FPS}")
    if out.exists() or out.is_symlink():
        raise LeRobotExportError(
            "the output folder exists", source=str(out), fix="give a new -o folder (or remove this one)"
        )
    if not out.parent.is_dir():
        raise LeRobotExportError(
            "the output's parent folder is missing", source=str(out.parent), fix="create it first"
        )
    episodes = read_episodes(recording)
    tmp = out.parent / f".{out.name}.partial-{os.getpid()}"
    if tmp.exists():
        shutil.rmtree(tmp)
    tmp.mkdir()
    try:
        info = _write(episodes, tmp, fps)
        if out.exists():  # appeared while we wrote
            raise LeRobotExportError("the output folder exists", source=str(out), fix="give a new -o folder")
        tmp.rename(out)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    return info


def _write(episodes: list[Episode], root: Path, fps: int) -> dict:
    import pyarrow as pa
    import pyarrow.parquet as pq

    full = episodes[0].entry.mode == "full"
    image_hw = depth_hw = None
    if full:
        image_hw = rgb_frame(episodes[0], 0).shape[:2]
        if max(image_hw) > MAX_FRAME_SIDE:
            raise LeRobotExportError(
                f"frames are {image_hw[1]} x {image_hw[0]}, more than {MAX_FRAME_SIDE} pixels a side",
                source=str(episodes[0].source),
                field=f"{episodes[0].name}: steps[0].obs.rgb_path",
                fix="record with the env's camera sizes",
            )
        if image_hw[0] % 2 or image_hw[1] % 2:
            raise LeRobotExportError(
                f"frames are {image_hw[1]} x {image_hw[0]}; H.264 (yuv420p) needs even sides",
                source=str(episodes[0].source),
                field=f"{episodes[0].name}: steps[0].obs.rgb_path",
                fix="record with an even camera width and height",
            )
        first = episodes[0].entry.steps[0].obs
        depth_hw = tuple(first.depth_shape) if first.depth is not None else None  # an RGB-only camera: none
    features = _features(fps, image_hw, depth_hw)
    tasks: dict[str, int] = {}
    for ep in episodes:
        tasks.setdefault(ep.task, len(tasks))
    schema = pa.schema([(k, _arrow_type(pa, ft)) for k, ft in features.items() if ft["dtype"] != "video"])

    rows, all_stats, index = [], [], 0
    for file_k, group in enumerate(_groups(episodes)):
        writer = pq.ParquetWriter(
            root / _mkparent(root, _file_path(DATA_PATH, file_k)),
            schema,
            compression="snappy",
            use_dictionary=True,
        )
        video = None
        if full:
            video_rel = _file_path(VIDEO_PATH, file_k, video_key=CAMERA_KEY)
            video = _Encoder(root / video_rel, image_hw, fps)
        frame_in_file = 0
        try:
            for k in group:
                ep = episodes[k]
                cols, frames = _episode_columns(ep, k, index, tasks[ep.task], fps, image_hw, depth_hw)
                if video is not None:
                    for f in frames:
                        video.write(f)
                arrays = [_column(pa, cols[f.name], f.type) for f in schema]
                writer.write_table(pa.Table.from_arrays(arrays, schema=schema))
                stats = _episode_stats(cols, frames)
                all_stats.append(stats)
                n = len(ep.entry.steps)
                row = {
                    "episode_index": k,
                    "tasks": [ep.task],
                    "length": n,
                    "data/chunk_index": file_k // CHUNKS_SIZE,
                    "data/file_index": file_k % CHUNKS_SIZE,
                    "dataset_from_index": index,
                    "dataset_to_index": index + n,
                }
                if video is not None:
                    row |= {
                        f"videos/{CAMERA_KEY}/chunk_index": file_k // CHUNKS_SIZE,
                        f"videos/{CAMERA_KEY}/file_index": file_k % CHUNKS_SIZE,
                        f"videos/{CAMERA_KEY}/from_timestamp": frame_in_file / fps,
                        f"videos/{CAMERA_KEY}/to_timestamp": (frame_in_file + n) / fps,
                    }
                row |= {
                    "biovln/scene_id": ep.entry.scene_id,
                    "biovln/episode_id": ep.entry.episode_id,
                    "biovln/object_id": ep.entry.object_id,
                    "biovln/difficulty": ep.entry.difficulty,
                    "biovln/success": ep.entry.success,
                }
                row |= {f"stats/{key}/{s}": v for key, d in sorted(stats.items()) for s, v in d.items()}
                rows.append(row)
                index += n
                frame_in_file += n
        except BaseException:
            if video is not None:
                video.abort()
            raise
        finally:
            writer.close()
        if video is not None:
            video.close()

    _write_episode_rows(rows, root)
    task_table = pa.table(
        {
            "task_index": pa.array(list(tasks.values()), pa.int64()),
            "__index_level_0__": pa.array(list(tasks), pa.string()),
        }
    )
    task_table = task_table.replace_schema_metadata({b"pandas": _pandas_index_metadata()})
    pq.write_table(task_table, root / _mkparent(root, "meta/tasks.parquet"), compression="snappy")
    atomic_write_text(
        root / "meta" / "stats.json", json.dumps(_jsonable(_combine(all_stats)), separators=(",", ":")) + "\n"
    )
    info = {
        "codebase_version": CODEBASE_VERSION,
        "robot_type": None,
        "total_episodes": len(episodes),
        "total_frames": index,
        "total_tasks": len(tasks),
        "chunks_size": CHUNKS_SIZE,
        "data_files_size_in_mb": 100,
        "video_files_size_in_mb": 200,
        "fps": fps,
        "splits": {"train": f"0:{len(episodes)}"},
        "data_path": DATA_PATH,
        "video_path": VIDEO_PATH if full else None,
        "features": features,
    }
    atomic_write_text(root / "meta" / "info.json", json.dumps(info, indent=4) + "\n")
    return info


def _mkparent(root: Path, rel: str) -> str:
    (root / rel).parent.mkdir(parents=True, exist_ok=True)
    return rel


def _column(pa, values: np.ndarray, type_):
    """One parquet column from a numpy array, without a Python object per element: scalars, fixed-size
    lists (vectors) or lists of fixed-size lists (2-D arrays, as datasets' Array2D stores them)."""
    flat = pa.array(np.ascontiguousarray(values).ravel())
    if values.ndim == 1:
        return flat
    if values.ndim == 2:
        return pa.FixedSizeListArray.from_arrays(flat, values.shape[1])
    n, h, w = values.shape
    rows = pa.FixedSizeListArray.from_arrays(flat, w)
    return pa.ListArray.from_arrays(pa.array(np.arange(0, (n + 1) * h, h, dtype=np.int32)), rows, type=type_)


def _episode_columns(ep: Episode, k: int, index: int, task_index: int, fps: int, image_hw, depth_hw):
    """The data columns of one episode (numpy) and its RGB frames (N x H x W x 3, or None)."""
    steps = ep.entry.steps
    n = len(steps)
    frames = None
    cols: dict[str, np.ndarray] = {}
    if image_hw is not None:
        frames = np.empty((n, *image_hw, 3), np.uint8)
        depth = None if depth_hw is None else np.empty((n, *depth_hw), np.float32)
        for i in range(n):
            img = rgb_frame(ep, i)
            if img.shape[:2] != tuple(image_hw):
                raise LeRobotExportError(
                    f"frame is {img.shape[1]} x {img.shape[0]}, the recording's first is "
                    f"{image_hw[1]} x {image_hw[0]}",
                    source=str(ep.source),
                    field=f"{ep.name}: steps[{i}].obs.rgb_path",
                    fix="export recordings made with one camera size",
                )
            frames[i] = img
            if depth is None:
                continue
            if steps[i].obs.depth is None:
                raise LeRobotExportError(
                    "a step without depth in a recording with depth",
                    source=str(ep.source),
                    field=f"{ep.name}: steps[{i}].obs.depth",
                    fix="export recordings made with one camera",
                )
            d = depth_frame(ep, i)
            if d.shape != tuple(depth_hw):
                raise LeRobotExportError(
                    f"depth is {d.shape[1]} x {d.shape[0]}, the recording's first is "
                    f"{depth_hw[1]} x {depth_hw[0]}",
                    source=str(ep.source),
                    field=f"{ep.name}: steps[{i}].obs.depth_shape",
                    fix="export recordings made with one depth size",
                )
            depth[i] = d
        if depth is not None:
            cols[DEPTH_KEY] = depth
    cols["observation.state"] = np.array(
        [[s.obs.position[0], s.obs.position[1], *s.obs.heading] for s in steps], np.float32
    )
    cols["observation.goal_position"] = np.array([s.obs.goal_position for s in steps], np.float32)
    cols["observation.dist_to_goal"] = np.array([s.dist_to_goal for s in steps], np.float32)
    cols["action"] = np.array([s.action for s in steps], np.int64)
    done = np.zeros(n, bool)
    done[-1] = True
    cols["next.done"] = done
    cols["next.success"] = done & ep.entry.success
    cols["timestamp"] = (np.arange(n, dtype=np.float64) / fps).astype(np.float32)
    cols["frame_index"] = np.arange(n, dtype=np.int64)
    cols["episode_index"] = np.full(n, k, np.int64)
    cols["index"] = np.arange(index, index + n, dtype=np.int64)
    cols["task_index"] = np.full(n, task_index, np.int64)
    return cols, frames


def _write_episode_rows(rows: list[dict], root: Path) -> None:
    """meta/episodes: the rows in files of at most ``EPISODE_META_BYTES`` (estimated from the stats)."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    def size(row: dict) -> int:
        return sum(np.asarray(v).nbytes if isinstance(v, np.ndarray) else 16 for v in row.values())

    files, current, n = [], [], 0
    for row in rows:
        if current and n + size(row) > EPISODE_META_BYTES:
            files.append(current)
            current, n = [], 0
        current.append(row)
        n += size(row)
    files.append(current)
    for file_k, group in enumerate(files):
        for row in group:
            row["meta/episodes/chunk_index"] = file_k // CHUNKS_SIZE
            row["meta/episodes/file_index"] = file_k % CHUNKS_SIZE
        columns = {key: [_plain(r[key]) for r in group] for key in group[0]}
        table = pa.table(columns)
        pq.write_table(table, root / _mkparent(root, _file_path(EPISODES_PATH, file_k)), compression="snappy")


def _plain(v):
    return v.tolist() if isinstance(v, np.ndarray) else v


def _pandas_index_metadata() -> bytes:
    """pandas metadata naming the task text column as the index (``pd.read_parquet`` restores it as
    LeRobot's ``meta.tasks`` expects: ``tasks.iloc[task_index].name`` is the task)."""
    return json.dumps(
        {
            "index_columns": ["__index_level_0__"],
            "column_indexes": [],
            "columns": [
                {
                    "name": "task_index",
                    "field_name": "task_index",
                    "pandas_type": "int64",
                    "numpy_type": "int64",
                    "metadata": None,
                },
                {
                    "name": None,
                    "field_name": "__index_level_0__",
                    "pandas_type": "unicode",
                    "numpy_type": "object",
                    "metadata": None,
                },
            ],
            "creator": {"library": "pyarrow"},
            "pandas_version": "2.0.0",
        }
    ).encode()
