"""A scene change does not pay for walking the whole process: ManiSkill ends each one with a full garbage
collection, so what is alive before an env is made is frozen (``FreezesLiveObjects``), Numba's registries
included, and the envs of a process share their split's episodes. Old scenes and closed envs are still
freed. In subprocesses: a freeze is for the whole process."""

from __future__ import annotations

import subprocess
import sys

import pytest

from biovln_ms.splits import dataset_root

_SCENE_CHANGES = """
import gc, resource, weakref
import gymnasium as gym
import biovln_ms
from biovln_ms.sim import maniskill_compat
freezes, freeze = [], gc.freeze
gc.freeze = lambda: (freezes.append(1), freeze())[1]
env = gym.make("BioVLN-OpFace-RL-v0", split="train", obs_mode="state")
assert freezes == [1] and gc.get_freeze_count() > 100_000  # the libraries and the episodes
env.reset(seed=0)
n = len(env.unwrapped.source)
peak = []
for k in range(45):  # a new scene at (nearly) every reset
    env.reset(options={"episode_index": (k * 37) % n})
    if k % 15 == 14:
        peak.append(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss)
unfrozen = len(gc.get_objects())  # what the collection at a scene change walks: the env and its scene,
assert unfrozen < 20_000, unfrozen  # not Numba's typing registries (built before the freeze) nor the episodes
assert peak[-1] - peak[0] < 0.1 * peak[0], peak  # old scenes freed: peak memory flat
same = gym.make("BioVLN-OpFace-RL-v0", split="train", obs_mode="state")
assert same.unwrapped.source is env.unwrapped.source  # one read of the split for both envs
same.reset(seed=0)
assert len(gc.get_objects()) - unfrozen < 10_000  # not a copy of its episodes for the walk
same.close()
del same
second = gym.make("BioVLN-OpFace-RL-v0", split="ms_val", obs_mode="state")
assert freezes == [1]  # once per process
maniskill_compat.FREEZE_EPISODES = 10  # a large split freezes again, but not while another env lives
second.close()
third = gym.make("BioVLN-OpFace-RL-v0", split="ms_val", obs_mode="state")
assert freezes == [1]
ref = weakref.ref(env.unwrapped)
for e in (env, second, third):
    e.close()
del env, second, third, e
gc.collect()
assert ref() is None  # an env is never frozen itself: closed and dropped, it is freed
gym.make("BioVLN-OpFace-RL-v0", split="ms_val", obs_mode="state").close()
assert freezes == [1, 1]
"""


@pytest.mark.slow
def test_the_first_env_freezes_the_live_objects_and_old_scenes_are_freed():
    dataset_root(None)  # built here: a build in the subprocess would run Numba's kernels before its freeze
    subprocess.run([sys.executable, "-c", _SCENE_CHANGES], check=True, timeout=600)
