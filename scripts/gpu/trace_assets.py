"""Which files of the installed ``mani_skill`` package a BioVLN-MS run opens (Python and C++ alike).

    python scripts/gpu/trace_assets.py [--out keep.txt]

Watches every folder of the package with Linux inotify (``IN_OPEN``, no strace needed), then runs what
the GPU benchmark runs, on the CPU: ``BioVLN-OpFace-v0`` / ``-Centroid-v0`` / ``-RL-v0`` (state and RGB-D)
and ManiSkill's ``PickCube-v1`` (state and RGB-D, its default robot, controller and table scene).
Prints the non-Python files opened, relative to the package folder: the asset keep list of
``scripts/gpu/repack_maniskill.py`` (its ``KEEP_ASSETS``) is this list.
"""

from __future__ import annotations

import argparse
import ctypes
import ctypes.util
import os
import struct
import sys
import threading
from pathlib import Path

IN_OPEN = 0x00000020
IN_NONBLOCK = 0o4000


class Inotify:
    def __init__(self, root: Path) -> None:
        self.libc = ctypes.CDLL(ctypes.util.find_library("c"), use_errno=True)
        self.fd = self.libc.inotify_init1(IN_NONBLOCK)
        if self.fd < 0:
            raise OSError(ctypes.get_errno(), "inotify_init1")
        self.dirs: dict[int, Path] = {}
        for d, _, _ in os.walk(root):
            wd = self.libc.inotify_add_watch(self.fd, os.fsencode(d), IN_OPEN)
            if wd < 0:
                raise OSError(ctypes.get_errno(), f"inotify_add_watch {d}")
            self.dirs[wd] = Path(d)
        self.seen: set[Path] = set()
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._loop, daemon=True)
        self._thread.start()

    def _drain(self) -> None:
        while True:
            try:
                buf = os.read(self.fd, 1 << 16)
            except BlockingIOError:
                return
            i = 0
            while i < len(buf):
                wd, _mask, _cookie, n = struct.unpack_from("iIII", buf, i)
                name = buf[i + 16 : i + 16 + n].rstrip(b"\0").decode()
                i += 16 + n
                if name:
                    self.seen.add(self.dirs[wd] / name)

    def _loop(self) -> None:
        while not self._stop.wait(0.05):
            self._drain()

    def stop(self) -> set[Path]:
        self._stop.set()
        self._thread.join()
        self._drain()
        return self.seen


def workload() -> None:
    import gymnasium as gym
    import numpy as np
    import torch

    import biovln_ms  # noqa: F401
    import mani_skill.envs  # noqa: F401

    cpu = dict(sim_backend="physx_cpu", render_backend="cpu", num_envs=1)
    rng = np.random.default_rng(0)
    for uid in ("BioVLN-OpFace-v0", "BioVLN-Centroid-v0", "BioVLN-OpFace-RL-v0"):
        for obs_mode in ("state", "rgbd"):
            env = gym.make(uid, split="ms_val", obs_mode=obs_mode, camera_width=128, camera_height=128, **cpu)
            env.reset(seed=0)
            for _ in range(5):
                env.step(torch.as_tensor(rng.integers(1, 4, 1)))
            if obs_mode == "rgbd":
                env.unwrapped.render_rgb_array()
            env.close()
    for obs_mode in ("state", "rgbd"):
        env = gym.make("PickCube-v1", obs_mode=obs_mode, **cpu)
        env.reset(seed=0)
        for _ in range(5):
            env.step(torch.as_tensor(env.action_space.sample()))
        if obs_mode == "rgbd":
            env.unwrapped.render_rgb_array()
        env.close()


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", type=Path)
    args = ap.parse_args()
    import importlib.util

    root = Path(importlib.util.find_spec("mani_skill").origin).parent
    watch = Inotify(root)
    workload()
    seen = watch.stop()
    rel = sorted(
        str(p.relative_to(root.parent))
        for p in seen
        if p.is_file() and p.suffix not in (".py", ".pyc") and "__pycache__" not in p.parts
    )
    text = "".join(f"{r}\n" for r in rel)
    sys.stdout.write(text)
    if args.out:
        args.out.write_text(text)


if __name__ == "__main__":
    main()
