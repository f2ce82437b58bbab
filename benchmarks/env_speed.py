"""Speed of the BioVLN-OpFace-v0 env on this machine, against raw SAPIEN measured in the same run.

    python benchmarks/env_speed.py [--steps 300] [--resets 1000]

Reports (budgets from the issue in brackets):
* steps/s at 640x480 RGB-D vs raw SAPIEN rendering the same frames (>= 0.95x): the walk's views replayed
  (``raw_camera_rate_at``: each step's robot pose, the same camera and read-back) in a second env after
  each block of the walk, the ratio the median over blocks (:func:`walk_against_raw`); beside it, raw SAPIEN
  rendering the walk's start view over and over (a view's cost varies with what it sees). The rows with
  people have only the latter (the replay does not place the people);
* steps/s at 640x480 depth only (the depth-only shader pack), beside the RGB-D rate;
* state-only steps/s (>= 3,000; ``step_profile.py`` gives the ratio to PickCube-v1); 128x128 RGB-D over
  raw SAPIEN (>= 0.85x);
* Fetch (``robot_uids="fetch"``, on its own default dataset) at 640x480 RGB-D and state only, beside the
  cylinder's rows;
* people: the ``busy_val`` episodes with their crowds at 640x480 RGB-D and state only, over the same episodes
  in an empty lab (``people=0``): interleaved blocks of the same actions, the median of their ratios
  (<= 1.25x); a person collision does not end a busy episode here, so both envs reset together;
* the ``realistic`` preset's own work per step (actuation noise, no-sliding, RGB and depth noise, base-frame
  extrinsics) over the rest of the same walk's 640x480 RGB-D step, the ideal step on that path at the same
  moment (<= 5 %; over the ideal row's step beside it), and, end to end, its sensing on the ideal path
  (the same steps and views, interleaved with an ideal env);
* reset to a new episode in the same scene (<= 20 ms), to a scene met for the first time (<= 0.5 s) and to
  one met before (the env keeps its navigation geometry), in a fresh process as a vector env's worker
  meets them; the last also in this process after the envs above (a process's first env freezes what
  lives, so a later env's episodes are walked at each scene change);
* resident memory over ``--resets`` resets alternating scenes (flat).

The table goes to ``docs/data/benchmarks/env_speed.json`` (``--data-out``), which the docs' benchmarks
page renders.
"""

from __future__ import annotations

import argparse
import gc
import resource
import time
from pathlib import Path

import gymnasium as gym
import numpy as np
import torch

import biovln_ms  # noqa: F401
from biovln_ms.measured import (
    BUSY_VAL_CROWDED,
    BUSY_VAL_EMPTY,
    docs_data_dir,
    in_fresh_process,
    timed,
    write_table,
)
from biovln_ms.render.sapien_utils import raw_camera_rate, raw_camera_rate_at, vulkan_device_label

CPU = dict(sim_backend="physx_cpu", render_backend="cpu")
#: blocks a walk is split into, each followed by raw SAPIEN frames of its views (:func:`walk_against_raw`)
BLOCKS = 10
NOTES = [
    f"The ratio at the walk's views is the median over {BLOCKS} blocks, each of the walk's steps then raw "
    "SAPIEN frames of the same views in a second env, so the machine's changing speed during the run moves "
    "it less than two rates measured one after the other (the rates beside it are the blocks' totals). Rows "
    "without that reference (state only, busy_val with its people) are plain walks.",
    "Resets are timed in a fresh process, as a vector env's worker meets them; beside them, in the "
    "benchmark's own process after its other envs.",
    "The busy_val rows' steps/s are separate walks, each at its moment's machine load; the busy cost "
    "(their budget column) is the median ratio of interleaved blocks of the same actions: the comparison "
    "to read, where the two disagree.",
]


def rss_mb() -> float:
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def time_noise_work(env) -> dict[str, float]:
    """Wrap the noise work of ``env`` (actuation noise, the no-sliding check, the image noise models, the
    camera extrinsics re-expressed in the base frame without GPS+compass) with a timer; the returned dict's
    ``"noise"`` accumulates its seconds. Under actuation noise the robot takes another path than the ideal
    run, and a frame's cost depends on what it sees, so the end-to-end ratio of two runs mixes the noise's
    cost with the views'; this is the noise's own."""
    u, spent = env.unwrapped, {"noise": 0.0}

    def time_controllers():  # the locomotion controllers are made anew when a scene is built
        for controller in u.agent.controllers.values():
            controller._perturb = timed(controller._perturb, spent, "noise")
            controller._no_sliding = timed(controller._no_sliding, spent, "noise")

    load_agent = u._load_agent

    def load_and_time(options):
        load_agent(options)
        time_controllers()

    u._load_agent = load_and_time
    time_controllers()
    noise = u._head_noise
    noise.camera_params_in_base_frame = timed(noise.camera_params_in_base_frame, spent, "noise")
    noise.apply_image_noise = timed(noise.apply_image_noise, spent, "noise")
    return spent


def interleaved_ratio(envs, steps: int, block: int, after_block=None) -> float:
    """The median over block pairs of ``envs[1]``'s time over ``envs[0]``'s for the same random actions:
    blocks of ``block`` steps alternate between the two envs (which goes first alternating too), so a burst
    of machine noise in one block does not decide it. ``after_block`` runs after each pair, untimed."""
    actions = np.random.default_rng(0).integers(1, 4, steps).tolist()
    ratios = []
    for start in range(0, steps, block):
        spent = [0.0, 0.0]
        for i in (0, 1) if (start // block) % 2 == 0 else (1, 0):
            t = time.perf_counter()
            for a in actions[start : start + block]:
                _, _, term, trunc, _ = envs[i].step(a)
                if bool(term) or bool(trunc):
                    envs[i].reset()
            spent[i] = time.perf_counter() - t
        ratios.append(spent[1] / spent[0])
        if after_block is not None:
            after_block()
    return float(np.median(ratios))


def same_path_overhead(steps: int, block: int = 20) -> float:
    """End to end on one path: ``ideal`` against the ``realistic`` preset's sensing (RGB and depth noise, no
    GPS+compass, so base-frame extrinsics) with exact, sliding motion, at 640x480 RGB-D. Both robots take the
    same actions, hence the same path and the same views (checked after every block, outside the timing);
    the result is :func:`interleaved_ratio` of the sensing env over the ideal one, minus 1."""
    sensing = {"preset": "realistic", "actuation": 0.0, "sliding": True}
    envs = []
    try:
        for noise in ("ideal", sensing):
            envs.append(
                gym.make(
                    "BioVLN-OpFace-v0",
                    split="ms_val",
                    obs_mode="rgbd",
                    camera_width=640,
                    camera_height=480,
                    noise=noise,
                    **CPU,
                )
            )
            envs[-1].reset(seed=0, options={"episode_index": 0})

        def same_path() -> None:
            if not np.array_equal(*(env.unwrapped._measures["agent_pose"] for env in envs)):
                raise RuntimeError(
                    "the ideal and sensing-only envs took different paths; the comparison is void"
                )

        return interleaved_ratio(envs, steps, block, same_path) - 1
    finally:
        for env in envs:
            env.close()


def walk_actions(env, steps: int) -> np.ndarray:
    """The seeded random walk (FORWARD, LEFT, RIGHT) of :func:`step_rate` and :func:`walk_against_raw`:
    ``env`` reset to episode 0 and 10 untimed warm-up steps taken, the ``steps`` actions to time."""
    rng = np.random.default_rng(0)
    env.reset(options={"episode_index": 0})
    for a in rng.integers(1, 4, 10):
        env.step(int(a))
    return rng.integers(1, 4, steps)


def step_rate(env, steps: int) -> float:
    """Steps/s of :func:`walk_actions`' walk, resetting at episode ends."""
    actions = walk_actions(env, steps)
    t = time.perf_counter()
    for a in actions:
        _, _, term, trunc, _ = env.step(int(a))
        if bool(term) or bool(trunc):
            env.reset()
    return steps / (time.perf_counter() - t)


def walk_against_raw(env, ref, steps: int) -> tuple[float, float, float]:
    """:func:`walk_actions`' walk in :data:`BLOCKS` blocks, each followed by raw SAPIEN frames of that
    block's own views (:func:`raw_camera_rate_at`) in ``ref``, an env made alike (the walk's state stays
    untouched): env steps/s, raw frames/s, and the median over blocks of the env's rate over raw's, which a
    change of the machine's speed during the run moves less than two rates measured one after the other."""
    actions, u = walk_actions(env, steps), env.unwrapped
    ref.reset(seed=0)
    env_s, raw_s, ratios = 0.0, 0.0, []
    for block in np.array_split(actions, BLOCKS):
        views = []
        t = time.perf_counter()
        for a in block:
            _, _, term, trunc, _ = env.step(int(a))
            views.append((u._episode_index[0], u.agent.robot.get_qpos().clone()))
            if bool(term) or bool(trunc):
                env.reset()
        walked = time.perf_counter() - t
        rendered = len(views) / raw_camera_rate_at(ref, views)
        env_s, raw_s = env_s + walked, raw_s + rendered
        ratios.append(rendered / walked)
    return steps / env_s, steps / raw_s, float(np.median(ratios))


def reference_cell(rate: float, raw: float | None, ratio: float | None, start: float | None) -> str:
    """The table's raw SAPIEN column: the walk's own frames (the budget's reference: the median ratio of the
    interleaved blocks), then the start view."""
    cells = [f"raw SAPIEN {raw:.0f} frames/s at the walk's views ({ratio:.2f}×, interleaved)"] if raw else []
    cells += [f"at its start view {start:.0f} ({rate / start:.2f}×)"] if start else []
    return "; ".join(cells)


def _reset_time(env, episode_index: int) -> float:
    t = time.perf_counter()
    env.reset(options={"episode_index": episode_index})
    return time.perf_counter() - t


def reset_times() -> tuple[list[float], list[float], list[float]]:
    """Seconds of resets of a state-only env on ``train`` (scenes enough for 12 first visits): to an episode
    of the same scene, to a scene met for the first time, and to one met before (its geometry kept)."""
    torch.set_num_threads(1)
    env = gym.make("BioVLN-OpFace-v0", split="train", obs_mode="state", **CPU)
    by_scene = env.unwrapped.source.by_scene()
    scenes = list(by_scene)[:13]
    env.reset(options={"episode_index": by_scene[scenes[0]][0]})
    same, first, again = [], [], []
    for k in range(1, 40):
        same.append(_reset_time(env, by_scene[scenes[0]][k % len(by_scene[scenes[0]])]))
    for times in (first, again):
        for scene in scenes[1:]:
            times.append(_reset_time(env, by_scene[scene][0]))
    env.close()
    return same, first, again


def busy_cost(obs_mode: str, size: tuple[int, int], steps: int, block: int) -> float:
    """A busy step's time over an empty-lab step on the ``busy_val`` episodes (``people=0``): the
    :func:`interleaved_ratio` of the busy env over the empty one. A person collision does not end the busy
    env's episode (``person_collision_ends=False``; it is still cut and counted), so both envs run the same
    episodes and reset together at the step limit: the ratio is the step's, not that of extra resets."""
    envs = []
    try:
        for where in (BUSY_VAL_EMPTY, BUSY_VAL_CROWDED):
            envs.append(
                gym.make(
                    "BioVLN-OpFace-v0",
                    obs_mode=obs_mode,
                    camera_width=size[0],
                    camera_height=size[1],
                    **where,
                    **CPU,
                )
            )
            envs[-1].reset(seed=0, options={"episode_index": 0})
        return interleaved_ratio(envs, steps, block)
    finally:
        for env in envs:
            env.close()


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--steps", type=int, default=300)
    ap.add_argument("--resets", type=int, default=1000)
    ap.add_argument("--data-out", type=Path, default=docs_data_dir() / "benchmarks" / "env_speed.json")
    args = ap.parse_args()
    torch.set_num_threads(1)
    rows, noise_seconds = [], {}
    for label, obs_mode, w, h, noise, robot, where in (
        ("640x480 RGB-D", "rgbd", 640, 480, "ideal", "biovln_base", {}),
        ("640x480 RGB-D, noise=realistic", "rgbd", 640, 480, "realistic", "biovln_base", {}),
        ("640x480 depth (the depth-only shader pack)", "depth", 640, 480, "ideal", "biovln_base", {}),
        ("128x128 RGB-D", "rgbd", 128, 128, "ideal", "biovln_base", {}),
        ("state only", "state", 128, 128, "ideal", "biovln_base", {}),
        ("Fetch, 640x480 RGB-D", "rgbd", 640, 480, "ideal", "fetch", {}),
        ("Fetch, state only", "state", 128, 128, "ideal", "fetch", {}),
        ("busy_val empty, 640x480 RGB-D", "rgbd", 640, 480, "ideal", "biovln_base", BUSY_VAL_EMPTY),
        ("busy_val, 640x480 RGB-D", "rgbd", 640, 480, "ideal", "biovln_base", BUSY_VAL_CROWDED),
        ("busy_val empty, state only", "state", 128, 128, "ideal", "biovln_base", BUSY_VAL_EMPTY),
        ("busy_val, state only", "state", 128, 128, "ideal", "biovln_base", BUSY_VAL_CROWDED),
    ):
        kwargs = dict(obs_mode=obs_mode, camera_width=w, camera_height=h, noise=noise, robot_uids=robot)
        kwargs.update({"split": "ms_val", **where, **CPU})
        env = gym.make("BioVLN-OpFace-v0", **kwargs)
        env.reset(seed=0)
        start = raw_camera_rate(env, max(20, args.steps // 5)) if obs_mode != "state" else None
        spent = time_noise_work(env) if noise != "ideal" else {"noise": 0.0}
        steps = args.steps if obs_mode != "state" else args.steps * 5
        # the walk's own frames are replayed for raw SAPIEN, which places no people: not for the busy env
        if obs_mode != "state" and where is not BUSY_VAL_CROWDED:
            ref = gym.make("BioVLN-OpFace-v0", **kwargs)
            rate, raw, ratio = walk_against_raw(env, ref, steps)
            ref.close()
        else:
            rate, raw, ratio = step_rate(env, steps), None, None
        rows.append((label, rate, raw, ratio, start))
        noise_seconds[label] = spent["noise"] / (steps + 10)  # per step, the 10 warm-up steps included
        env.close()
    nan = float("nan")
    head = ("env steps/s", "raw, walk views", "ratio", "raw, start view", "ratio")
    print(f"{'mode':<44} {head[0]:>12} {head[1]:>16} {head[2]:>6} {head[3]:>16} {head[4]:>6}")
    for label, rate, raw, ratio, start in rows:
        print(
            f"{label:<44} {rate:12.0f} {raw or nan:16.0f} {ratio or nan:6.2f} "
            f"{start or nan:16.0f} {rate / start if start else nan:6.2f}"
        )
    end_to_end = rows[0][1] / rows[1][1] - 1  # another path, other views: see time_noise_work
    # the realistic walk's noise work per step over the rest of the same walk's step (the ideal step on that
    # path, at the same moment), and over the ideal row's step (another walk, minutes apart)
    noise = noise_seconds["640x480 RGB-D, noise=realistic"]
    overhead, over_ideal_row = noise / (1 / rows[1][1] - noise), noise * rows[0][1]
    print(
        f"realistic noise: its work costs {100 * overhead:.1f} % of the rest of its walk's 640x480 RGB-D "
        f"step (budget <= 5 %), {100 * over_ideal_row:.1f} % of the ideal row's step; end to end (another "
        f"path) {100 * end_to_end:+.1f} %"
    )
    sensing_steps = args.steps * 4
    sensing = same_path_overhead(sensing_steps)
    print(f"realistic's sensing on the ideal path, end to end (interleaved): {100 * sensing:+.1f} %")

    # Resets as a worker process meets them (its first env: the split's episodes frozen with the libraries),
    # and in this process after the envs above (the train split's episodes not frozen, so each scene
    # change's full collection walks them)
    fresh = in_fresh_process(reset_times)
    here = reset_times()
    for where, (same, first, again) in (("fresh process", fresh), ("after other envs", here)):
        print(
            f"reset ({where}), same scene: median {np.median(same) * 1e3:.1f} ms (budget 20 ms); new scene, "
            f"first visit: median {np.median(first) * 1e3:.0f} ms, max {max(first) * 1e3:.0f} ms (budget "
            f"500 ms); met before: median {np.median(again) * 1e3:.0f} ms"
        )
    same, first, again = fresh
    env = gym.make("BioVLN-OpFace-v0", split="ms_dev", obs_mode="state", **CPU)
    by_scene = env.unwrapped.source.by_scene()
    scenes = list(by_scene)
    gc.collect()
    gc.freeze()
    marks = {}
    for k in range(args.resets):
        scene = scenes[(k // 10) % len(scenes)]  # a new scene every 10 resets
        env.reset(options={"episode_index": by_scene[scene][k % len(by_scene[scene])]})
        if k + 1 in (100, args.resets // 2, args.resets):
            marks[k + 1] = rss_mb()
    print(
        "resident memory over resets (a new scene every 10): "
        + ", ".join(f"{k}: {v:.0f} MB" for k, v in marks.items())
    )
    env.close()
    budgets = {
        "640x480 RGB-D": "≥ 0.95× raw",
        "640x480 RGB-D, noise=realistic": "(see the noise's own work below)",
        "640x480 depth (the depth-only shader pack)": f"(RGB-D: {rows[0][1]:.0f} steps/s)",
        "128x128 RGB-D": "≥ 0.85× raw",
        "state only": "≥ 3,000 steps/s; ≥ 8× PickCube-v1 (step_profile)",
        "Fetch, 640x480 RGB-D": "(beside the cylinder's)",
        "Fetch, state only": "(beside the cylinder's)",
        "busy_val empty, 640x480 RGB-D": "(the next row's reference)",
        "busy_val empty, state only": "(the next row's reference)",
    }
    # a busy step's cost over the same episodes' empty step: interleaved blocks, the median of their ratios
    for mode, obs_mode, size, steps in (
        ("640x480 RGB-D", "rgbd", (640, 480), args.steps * 2),
        ("state only", "state", (128, 128), args.steps * 20),
    ):
        cost = busy_cost(obs_mode, size, steps, block=steps // 30)
        budgets[f"busy_val, {mode}"] = f"{cost:.2f}× an empty-lab step, interleaved (≤ 1.25×)"
        print(f"people, {mode}: a busy step costs {cost:.2f}x an empty-lab step (budget <= 1.25x)")
    table = [
        [
            label,
            f"{rate:.0f} steps/s",
            reference_cell(rate, raw, ratio, start),
            budgets[label],
        ]
        for label, rate, raw, ratio, start in rows
    ]
    table += [
        [
            "realistic noise's own work (actuation, no-sliding, RGB and depth noise, base-frame extrinsics)",
            f"{100 * overhead:.1f} % of the rest of its walk's 640x480 RGB-D step (its ideal step there)",
            f"{100 * over_ideal_row:.1f} % of the ideal row's step (another walk); end to end "
            f"{100 * end_to_end:+.1f} % (another path, other views: the next row is on one path)",
            "≤ 5 %",
        ],
        [
            "realistic's sensing (RGB and depth noise, base-frame extrinsics) on the ideal path, end to end",
            f"{100 * sensing:+.1f} % step time",
            f"ideal, the same {sensing_steps} steps and views; median over blocks of 20, interleaved",
            "(the own work above is the budget's measure)",
        ],
        [
            "reset, same scene (median)",
            f"{np.median(same) * 1e3:.1f} ms",
            f"{np.median(here[0]) * 1e3:.1f} ms in the benchmark's process",
            "≤ 20 ms",
        ],
        [
            "reset, new scene, first visit (median / max; 12 train scenes)",
            f"{np.median(first) * 1e3:.0f} / {max(first) * 1e3:.0f} ms",
            f"{np.median(here[1]) * 1e3:.0f} / {max(here[1]) * 1e3:.0f} ms in the benchmark's process",
            "≤ 500 ms",
        ],
        [
            "reset, new scene met before (median; its navigation geometry kept)",
            f"{np.median(again) * 1e3:.0f} ms",
            f"{np.median(here[2]) * 1e3:.0f} ms in the benchmark's process, whose first env was of another "
            "split (these episodes not frozen: each scene change's collection walks them)",
            "(the row above's reference)",
        ],
        [
            f"resident memory over {args.resets} resets (a new scene every 10)",
            ", ".join(f"{k}: {v:.0f} MB" for k, v in marks.items()),
            "",
            "flat",
        ],
    ]
    write_table(
        args.data_out,
        "BioVLN-OpFace-v0 speed, one env process",
        ["measure", "this version", "reference in the same run", "budget"],
        table,
        NOTES,
        render_device=vulkan_device_label(),
    )


if __name__ == "__main__":
    main()
