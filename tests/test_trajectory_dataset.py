import numpy as np
import pytest
import torch

from biovln_ms.learning.dataset import TrajectoryDataError, TrajectoryDataset, Transforms, goal_vector
from biovln_ms.learning.recorder import TrajectoryRecorder


def _record(root, episodes, mode="trace", success=True):
    rec = TrajectoryRecorder(root, mode)
    for e in range(episodes):
        rec.start(
            {
                "scene_id": "s",
                "episode_id": str(e),
                "object_category": "cabinet",
                "object_id": "cabinet_0",
                "info": {"difficulty": "easy"},
            },
            (3.0, 0.0),
        )
        for k, a in enumerate([2, 1, 3, 0]):
            rec.step(k, a, (0.0, 0.0, 0.0), (3.0, 0.0), 3.0)
        rec.finish(success)
    return root


def test_goal_vector_is_agent_centric():
    v = goal_vector((0, 0), (1.0, 0.0), (3.0, 0.0))
    assert np.allclose(v, [1, 0, 3, 0.6])
    v = goal_vector((0, 0), (0.0, 1.0), (3.0, 0.0))  # facing +y, goal along +x is to the right (y < 0)
    assert np.allclose(v[:2], [0, -1], atol=1e-6)
    assert goal_vector((0, 0), (1, 0), (10, 0))[3] == 1.0


def test_trace_dataset_lazy_merge_drop_stop_and_flip(tmp_path):
    a = _record(tmp_path / "a", 3)
    b = _record(tmp_path / "b", 2)
    ds = TrajectoryDataset([a, b], require_images=False)
    assert len(ds) == 5 * 4 and ds.episodes == 5
    assert len(TrajectoryDataset([a, b], require_images=False, drop_stop=True)) == 5 * 3
    item = ds[0]
    assert item["goal"].shape == (4,) and item["action"].dtype == torch.long
    flipped = TrajectoryDataset(a, Transforms(hflip_p=1.0), require_images=False)
    assert [int(flipped[k]["action"]) for k in range(4)] == [3, 1, 2, 0]  # LEFT <-> RIGHT


def test_bad_recordings_are_named(tmp_path):
    with pytest.raises(TrajectoryDataError, match="no recordings here"):
        TrajectoryDataset(tmp_path / "empty")
    fails = _record(tmp_path / "f", 2, success=False)
    with pytest.raises(TrajectoryDataError, match="none of the 2 recorded episodes succeeded"):
        TrajectoryDataset(fails, require_images=False)
    trace = _record(tmp_path / "t", 1)
    with pytest.raises(TrajectoryDataError, match="trace-only recordings have no images"):
        TrajectoryDataset(trace)
    import biovln_ms.learning.recorder as r

    old = r.RECORDER_VERSION
    r.RECORDER_VERSION = 99
    try:
        _record(tmp_path / "t", 1)
    finally:
        r.RECORDER_VERSION = old
    with pytest.raises(TrajectoryDataError, match="recordings of versions"):
        TrajectoryDataset(tmp_path / "t", require_images=False)


def test_recordings_from_elsewhere_are_bounded(tmp_path, monkeypatch):
    import gzip
    import json

    import biovln_ms.learning.recordings as recordings
    from biovln_ms.learning.recorder import RECORDER_VERSION

    # a frame path that leaves the recording folder is refused when the frame is read
    root = tmp_path / "r"
    root.mkdir()
    step = {
        "step_idx": 0,
        "action": 1,
        "obs": {"position": [0, 0, 0], "heading": [1, 0], "goal_position": [3, 0], "rgb_path": "../x.png"},
    }
    entry = {"recorder_version": RECORDER_VERSION, "mode": "full", "success": True, "steps": [step]}
    (root / "trajectories-0.jsonl.gz").write_bytes(gzip.compress((json.dumps(entry) + "\n").encode()))
    ds = TrajectoryDataset(root)
    with pytest.raises(TrajectoryDataError, match="obs.rgb_path"):
        ds[0]
    # an episode that decompresses past the bound stops there (a gzip bomb)
    monkeypatch.setattr(recordings, "MAX_ENTRY_BYTES", 100)
    with pytest.raises(recordings.RecordingReadError, match="decompresses to more than"):
        TrajectoryDataset(_record(tmp_path / "a", 1), require_images=False)
