"""A scene change does not pay for walking the whole process: ManiSkill ends each one with a full garbage
collection, so the env freezes what is alive when it is made (``freeze_live_objects``). Old scenes are
still freed. In subprocesses: a freeze is for the whole process."""

from __future__ import annotations

import subprocess
import sys

import pytest

_SCENE_CHANGES = """
import gc, resource, time
import gymnasium as gym
import biovln_ms
from biovln_ms.sim import maniskill_compat
env = gym.make("BioVLN-OpFace-RL-v0", split="train", obs_mode="state")
assert gc.get_freeze_count() > 100_000  # the libraries and the episodes, frozen by the first env
env.reset(seed=0)
n = len(env.unwrapped.source)
peak = []
for k in range(45):  # a new scene at every reset (the split's scenes hold 30-40 episodes each)
    env.reset(options={"episode_index": (k * 37) % n})
    if k % 15 == 14:
        peak.append(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss)
unfrozen = len(gc.get_objects())
assert unfrozen < 0.5 * gc.get_freeze_count(), unfrozen  # what the collection at a scene change walks
assert peak[-1] - peak[0] < 0.1 * peak[0], peak  # old scenes freed: peak memory flat
frozen = gc.get_freeze_count()
gym.make("BioVLN-OpFace-RL-v0", split="ms_val", obs_mode="state").close()
assert gc.get_freeze_count() == frozen  # once per process
maniskill_compat.FREEZE_EPISODES = 10  # unless a split is large: then again
gym.make("BioVLN-OpFace-RL-v0", split="ms_val", obs_mode="state").close()
assert gc.get_freeze_count() > frozen
"""


@pytest.mark.slow
def test_the_first_env_freezes_the_live_objects_and_old_scenes_are_freed():
    subprocess.run([sys.executable, "-c", _SCENE_CHANGES], check=True, timeout=600)
