"""``DatasetEpisodes.shared``: envs of one process share a split's episodes while the dataset's files stand
as they were read, and a changed file is read (and verified) again."""

from __future__ import annotations

import gc
import gzip
import os
import shutil

import gymnasium as gym
import pytest

import biovln_ms  # noqa: F401

from biovln_ms.episodes.dataset import DatasetError
from biovln_ms.episodes import source
from biovln_ms.episodes.source import DatasetEpisodes
from biovln_ms.robot_specs import DEFAULT_ROBOT

EPISODES = "ms_val/content/lab_s154_v0.json.gz"


@pytest.fixture
def root(held_out_dataset, tmp_path):
    """A copy of a small dataset, free to edit."""
    dst = tmp_path / "ds"
    shutil.copytree(held_out_dataset(ms_val=3), dst)
    return dst


def test_same_split_same_object_while_held(root):
    a = DatasetEpisodes.shared("ms_val", root)
    b = DatasetEpisodes.shared("ms_val", str(root / ".." / "ds"))  # the same folder by another spelling
    assert a is b
    assert DatasetEpisodes.shared("ms_val", root, robot=DEFAULT_ROBOT) is a
    with pytest.raises(DatasetError, match="built for robot"):  # the robot is part of the key
        DatasetEpisodes.shared("ms_val", root, robot="fetch")
    assert len(a.episodes) == 3
    del a, b
    gc.collect()
    assert (str(root.resolve()), "ms_val", DEFAULT_ROBOT) not in source._SHARED  # held weakly only


def test_a_changed_file_is_read_again(root):
    a = DatasetEpisodes.shared("ms_val", root)
    path = root / EPISODES
    stat = path.stat()
    os.utime(path, ns=(stat.st_atime_ns, stat.st_mtime_ns + 2 * 10**9))  # touched: read again, still valid
    b = DatasetEpisodes.shared("ms_val", root)
    assert b is not a and b.episodes == a.episodes
    with gzip.open(path, "wt") as f:  # edited: its hash no longer matches the manifest
        f.write('{"episodes": []}')
    with pytest.raises(DatasetError, match="hash"):
        DatasetEpisodes.shared("ms_val", root)
    (root / EPISODES).unlink()  # gone
    with pytest.raises(DatasetError):
        DatasetEpisodes.shared("ms_val", root)


def test_envs_made_from_a_split_share_it(root):
    kw = dict(split="ms_val", dataset=str(root), obs_mode="state", render_backend="cpu")
    first, second = gym.make("BioVLN-OpFace-v0", **kw), gym.make("BioVLN-OpFace-v0", **kw)
    try:
        assert first.unwrapped.source is second.unwrapped.source
        first.reset(seed=0)
        second.reset(seed=0)
        assert first.unwrapped._episodes[0] is second.unwrapped._episodes[0]  # the same dict, not a copy
    finally:
        first.close()
        second.close()
