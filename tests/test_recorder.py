import gzip

import numpy as np
import pytest
from PIL import Image

from biovln_ms.eval.harness import EvalConfig, evaluate, load_records
from biovln_ms.learning.recorder import decode_depth, read_recordings


@pytest.fixture(scope="module")
def dataset(held_out_dataset):
    return held_out_dataset(ms_val=3)


@pytest.mark.parametrize("mode", ["full", "trace"])
def test_recorder_through_the_harness(dataset, tmp_path, mode):
    rec_dir = tmp_path / "rec"
    evaluate(
        EvalConfig(
            "oracle",
            "ms_val",
            str(tmp_path / "res"),
            dataset,
            workers=1,
            camera=(160, 120),
            record_dir=str(rec_dir),
            record_mode=mode,
        ),
        progress=False,
    )
    results = {
        (r["scene_id"], r["episode_id"]): r
        for r in load_records(tmp_path / "res" / "oracle" / "ms_val" / "episodes.jsonl")
    }
    (path,) = rec_dir.glob("trajectories-*.jsonl.gz")
    entries = list(read_recordings(path))
    assert len(entries) == 3
    for e in entries:
        r = results[(e["scene_id"], e["episode_id"])]
        assert e["frame"] == "z_up" and e["success"] == r["success"]
        assert [s["action"] for s in e["steps"]] == r["actions"]  # the policy's actions, unchanged
        s0 = e["steps"][0]
        assert s0["step_idx"] == 0 and set(s0["obs"]) >= {"position", "heading", "goal_position"}
        assert s0["success"] == e["success"] and "dist_to_goal" in s0
        assert np.hypot(*s0["obs"]["heading"]) == pytest.approx(1.0, abs=1e-4)
        if mode == "full":
            img = Image.open(rec_dir / s0["obs"]["rgb_path"])
            assert img.size == (224, 224)
            assert decode_depth(s0["obs"]).shape == (60, 80)
        else:
            assert "rgb_path" not in s0["obs"] and "depth" not in s0["obs"]
    assert (rec_dir / "images").exists() == (mode == "full")


def test_truncated_last_member_is_skipped(tmp_path):
    p = tmp_path / "t.jsonl.gz"
    p.write_bytes(gzip.compress(b'{"a": 1}\n') + gzip.compress(b'{"b": 2}\n')[:-7])
    assert list(read_recordings(p)) == [{"a": 1}]


def test_full_recordings_feed_the_trajectory_dataset(dataset, tmp_path):
    from biovln_ms.learning.dataset import TrajectoryDataset, Transforms

    rec_dir = tmp_path / "rec"
    evaluate(
        EvalConfig(
            "oracle",
            "ms_val",
            str(tmp_path / "res"),
            dataset,
            workers=1,
            camera=(160, 120),
            record_dir=str(rec_dir),
            record_mode="full",
        ),
        progress=False,
    )
    ds = TrajectoryDataset(
        rec_dir, Transforms(hflip_p=0.5, brightness=0.05, position_noise=0.02), drop_stop=True
    )
    item = ds[0]
    assert item["image"].shape == (3, 224, 224) and abs(float(item["image"].mean())) < 3
    assert item["goal"].shape == (4,) and int(item["action"]) in (1, 2, 3)
