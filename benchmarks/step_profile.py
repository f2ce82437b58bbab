"""Where a state-only step of BioVLN-OpFace-v0 spends its time, beside PickCube-v1 in the same run.

    python benchmarks/step_profile.py [--steps 3000] [--repeats 3]
    python benchmarks/step_profile.py --people [--steps 3000] [--repeats 3]
    python benchmarks/step_profile.py --crowd [--steps 400] [--repeats 7]
    python benchmarks/step_profile.py --camera 128x128 [--steps 600] [--repeats 3]

``--people`` times the same parts on the ``busy_val`` episodes with their crowds and with ``people=0``,
in interleaved blocks, plus the crowd's own step (``docs/data/benchmarks/busy_step_profile.json``).
``--crowd`` times the crowd's ``advance`` alone, replayed along the robot poses of 12 recorded ``busy_val``
walks, and prints a digest of the crowds' final states, so two versions can be compared for time and
sameness (``docs/data/benchmarks/crowd_step.json``).
``--camera WxH`` times an RGB-D step's parts at that head-camera size, the camera's two besides: submitting
the render (``start_capture``: the scene's render update and the pictures taken) and waiting for it and
reading it back (``_get_obs_sensor_data``, taken out of the observation's share), beside a raw SAPIEN frame of
the same camera timed in the same run (``docs/data/benchmarks/camera_step_profile.json``).

Each part of ``env.step`` is timed by a wrapper around the method that does it (no profiler, whose
overhead would inflate the Python parts): SAPIEN's physics (the control step's substeps), the robot's
command (action check, drive targets), the controller's end of step (swept check, put-back), the
measures, ``info``, the observation, the reward, and the rest (ManiSkill's and gymnasium's step code).
PickCube-v1 (``obs_mode="state"``, CPU physics) is the reference the issue's ratio divides by. The
table goes to ``docs/data/benchmarks/step_profile.json``.
"""

from __future__ import annotations

import argparse
import hashlib
import time
from pathlib import Path

import gymnasium as gym
import numpy as np
import torch

import biovln_ms  # noqa: F401
from biovln_ms.limits import parse_size
from biovln_ms.measured import BUSY_VAL_CROWDED, BUSY_VAL_EMPTY, docs_data_dir, timed, write_table
from biovln_ms.render.sapien_utils import raw_camera_rate
from biovln_ms.sim.maniskill_compat import maniskill_task_id

CPU = dict(sim_backend="physx_cpu", render_backend="cpu")


PARTS = (
    "SAPIEN physics",
    "robot command",
    "controller end of step",
    "measures",
    "info",
    "observation",
    "reward",
)


#: an RGB-D step's camera parts (:func:`camera_profile`)
SUBMIT, READ = "camera: render submitted", "camera: render waited for and read back"
#: what a step spends outside the timed parts
REST = "the rest (ManiSkill's and gymnasium's step code)"


def share_rows(per_step: dict[str, float], step_ms: float) -> list[list[str]]:
    """Table rows (part, ms per step, share) of the timed parts, the rest of the step and the whole step;
    printed as they go to the table."""
    parts = {**per_step, REST: step_ms - sum(per_step.values())}
    rows = [[part, f"{ms:.3f}", f"{100 * ms / step_ms:.0f} %"] for part, ms in parts.items()]
    rows.append(["whole step", f"{step_ms:.3f}", "100 %"])
    for r in rows:
        print(f"{r[0]:<52} {r[1]:>8} ms {r[2]:>6}")
    return rows


def _parts(env, spent: dict | None = None) -> dict[str, float]:
    """Wrap the methods that do each part of a step; the returned dict accumulates their seconds. Called
    again after a reset, it wraps what a new scene brought (its scene, robot, controller, people)."""
    u = env.unwrapped
    spent = dict.fromkeys(PARTS, 0.0) if spent is None else spent
    targets = [
        (u.scene, "step", "SAPIEN physics"),
        (u.agent, "set_action", "robot command"),
        (u.agent.controller, "end_step", "controller end of step"),
        (u._measures, "update", "measures"),
        (u, "get_info", "info"),
        (u, "get_obs", "observation"),
        (u, "get_reward", "reward"),
    ]
    if u._people is not None:
        spent.setdefault("the crowd's step", 0.0)
        targets.append((u._people, "step", "the crowd's step"))
    if SUBMIT in spent:  # camera_profile's parts
        targets += [(u, "start_capture", SUBMIT), (u, "_get_obs_sensor_data", READ)]
    for owner, name, key in targets:
        fn = getattr(owner, name)
        if not getattr(fn, "timed_part", False):  # a wrapper stays once: an object kept over a reset
            wrapped = timed(fn, spent, key)
            wrapped.timed_part = True
            setattr(owner, name, wrapped)
    return spent


def _run(env, steps: int, seed: int = 0, spent: dict | None = None) -> float:
    """Seconds for ``steps`` random steps (the nav env: FORWARD, LEFT, RIGHT), resetting at episode ends;
    with ``spent`` (from :func:`_parts`), what a reset rebuilt is wrapped too."""
    rng = np.random.default_rng(seed)
    sample = (lambda: int(rng.integers(1, 4))) if isinstance(env.action_space, gym.spaces.Discrete) else None
    t = time.perf_counter()
    for _ in range(steps):
        a = sample() if sample else env.action_space.sample()
        _, _, term, trunc, _ = env.step(a)
        if bool(term) or bool(trunc):
            env.reset()
            if spent is not None:
                _parts(env, spent)
    return time.perf_counter() - t


def people_profile(steps: int, repeats: int, out: Path) -> None:
    """The parts of a state-only step on the ``busy_val`` episodes, empty (``people=0``) and busy (their
    crowds; a person collision does not end the episode, so both run the same episodes' lengths)."""
    envs, spent = {}, {}
    for name, where in (("empty lab", BUSY_VAL_EMPTY), ("busy", BUSY_VAL_CROWDED)):
        env = gym.make("BioVLN-OpFace-v0", obs_mode="state", **where, **CPU)
        env.reset(seed=0, options={"episode_index": 0})
        _run(env, 300)  # warm-up: the scenes' geometry, the people's routes
        spent[name] = _parts(env)
        envs[name] = env
    totals = dict.fromkeys(envs, 0.0)
    for r in range(repeats):  # interleaved, so a busy moment of the machine costs both
        for name, env in envs.items():
            totals[name] += _run(env, steps, r, spent[name])
    n = steps * repeats
    parts = list(dict.fromkeys(k for d in spent.values() for k in d))
    ms = {name: {k: 1e3 * spent[name].get(k, 0.0) / n for k in parts} for name in envs}
    for name in envs:
        ms[name]["the rest (ManiSkill's and gymnasium's step code, resets)"] = 1e3 * totals[name] / n - sum(
            ms[name].values()
        )
        ms[name]["whole step"] = 1e3 * totals[name] / n
    rows = [[k, *(f"{ms[name][k]:.3f}" for name in envs)] for k in ms["busy"]]
    ratio = totals["busy"] / totals["empty lab"]
    notes = [
        f"{repeats} interleaved blocks of {steps} random FORWARD/LEFT/RIGHT steps per env, the parts timed "
        f"by wrappers in place; a busy step is {ratio:.2f}x an empty-lab step here.",
        "env_speed.py's budget ratio is the median of per-block ratios: another measure of the same cost.",
    ]
    for r in rows:
        print(f"{r[0]:<58} {r[1]:>8} {r[2]:>8} ms")
    print(notes[0])
    columns = ["part", *(f"{name}, ms per step" for name in envs)]
    write_table(out, "A state-only step with people: where the extra time goes", columns, rows, notes)
    for env in envs.values():
        env.close()


def camera_profile(size: tuple[int, int], steps: int, repeats: int, out: Path) -> None:
    """The parts of an RGB-D step at head-camera ``size``, the camera's submit and read-back apart, beside
    a raw SAPIEN frame (render update, picture, read-back) of the same camera in the same run."""
    w, h = size
    env = gym.make(
        "BioVLN-OpFace-v0", split="ms_val", obs_mode="rgbd", camera_width=w, camera_height=h, **CPU
    )
    env.reset(seed=0, options={"episode_index": 0})
    _run(env, 50)  # warm-up: shaders, the scenes' geometry
    spent = _parts(env, {**dict.fromkeys(PARTS, 0.0), SUBMIT: 0.0, READ: 0.0})
    total, raw = 0.0, []
    for r in range(repeats):  # interleaved with the raw frames, so a busy moment costs both
        total += _run(env, steps, r, spent)
        raw.append(1e3 / raw_camera_rate(env, steps // 4))
    n = steps * repeats
    ms = {k: 1e3 * v / n for k, v in spent.items()}
    ms["observation"] -= ms[READ]  # the read-back runs inside get_obs: each part counted once
    step_ms = 1e3 * total / n
    rows = share_rows(ms, step_ms)
    frame = float(np.median(raw))
    pictures = ms[SUBMIT] + ms[READ]
    notes = [
        f"{w}x{h} RGB-D, {repeats} blocks of {steps} random FORWARD/LEFT/RIGHT steps, each followed by "
        f"{steps // 4} raw SAPIEN frames of the same camera at the block's last view.",
        f"For scale, a raw SAPIEN frame at those views: {frame:.3f} ms (median of the blocks); a frame's "
        f"cost varies with the view, so the budget's ratio is env_speed.py's, over the walk's own views. The "
        f"step's camera parts {pictures:.3f} ms, its other parts {step_ms - pictures:.3f} ms.",
    ]
    print(*notes, sep="\n")
    write_table(
        out, f"Where a {w}x{h} RGB-D step spends its time", ["part", "ms per step", "share"], rows, notes
    )
    env.close()


def crowd_alone(steps: int, repeats: int, out: Path, episodes: int = 12) -> None:
    """``Crowd.advance`` alone, replayed along ``episodes`` recorded ``busy_val`` random walks (up to
    ``steps`` steps each, spread over the split's scenes): the robot's pose after each move, as the env
    hands it to the crowd. The first pass plans every route afresh (cold), the later ``repeats - 1`` reuse
    them (warm, the best kept). Every pass must end in the env's own final crowd (else it raises); the
    digest of the final crowds and waits tells whether two versions move the people alike."""
    env = gym.make("BioVLN-OpFace-v0", obs_mode="state", **BUSY_VAL_CROWDED, **CPU)
    total = len(env.unwrapped.source)
    rng = np.random.default_rng(0)
    walks = []
    for ep in np.linspace(0, total - 1, episodes).astype(int).tolist():
        env.reset(seed=ep, options={"episode_index": ep})
        u = env.unwrapped
        start, poses = u._people.crowds[0].state(), []
        for _ in range(steps):
            _, _, term, trunc, _ = env.step(int(rng.integers(1, 4)))
            poses.append(u._measures["agent_pose"][0, :2].copy())
            if bool(term) or bool(trunc):
                break
        walks.append((ep, start, poses, u._people.crowds[0].state()))
    cold, warm, digest, n = 0.0, 0.0, hashlib.sha256(), 0
    for ep, start, poses, end in walks:
        env.reset(seed=ep, options={"episode_index": ep})
        u = env.unwrapped
        crowd, seconds = u._people.crowds[0], u._people.seconds
        crowd._paths.clear()  # the scene's routes, planned while recording: the first pass plans its own
        times = []
        for _ in range(repeats):
            crowd.load(start)
            t = time.perf_counter()
            waits = [crowd.advance(seconds, p) for p in poses]
            times.append(time.perf_counter() - t)
            final = crowd.state()
            if not all(np.array_equal(final[k], end[k], equal_nan=True) for k in end):
                raise RuntimeError(f"episode {ep}: the replayed crowd differs from the env's")
        cold, warm, n = cold + times[0], warm + min(times[1:]), n + len(poses)
        for v in final.values():
            digest.update(np.ascontiguousarray(v).tobytes())
        digest.update(np.asarray(waits).tobytes())
    env.close()
    rows = [
        ["first pass (every route planned)", f"{1e6 * cold / n:.1f}"],
        [f"best of {repeats - 1} later passes (routes kept)", f"{1e6 * warm / n:.1f}"],
    ]
    notes = [
        f"{n} steps of {episodes} busy_val random walks over {len({e for e, *_ in walks})} episodes; every "
        f"pass ends in the env's own final crowds; their digest {digest.hexdigest()[:16]}."
    ]
    for r in rows:
        print(f"{r[0]:<40} {r[1]:>8} µs per step")
    print(notes[0])
    write_table(out, "The crowd's step alone (Crowd.advance)", ["pass", "µs per step"], rows, notes)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--steps", type=int, help="per block (default 3000; --crowd: per walk, 400)")
    ap.add_argument("--repeats", type=int, help="interleaved blocks per env (default 3; --crowd: passes, 7)")
    ap.add_argument("--data-out", type=Path, default=None, help="default: docs/data/benchmarks/<table>.json")
    mode = ap.add_mutually_exclusive_group()
    mode.add_argument("--people", action="store_true", help="the busy_val episodes with and without people")
    mode.add_argument("--crowd", action="store_true", help="the crowd's advance alone, replayed")
    mode.add_argument("--camera", metavar="WxH", help="an RGB-D step at this head-camera size")
    args = ap.parse_args()
    torch.set_num_threads(1)
    data = docs_data_dir() / "benchmarks"
    if args.crowd:
        repeats = 7 if args.repeats is None else args.repeats
        if repeats < 2:
            ap.error("--crowd needs --repeats 2 or more (a cold pass and a warm one)")
        out = args.data_out or data / "crowd_step.json"
        return crowd_alone(400 if args.steps is None else args.steps, repeats, out)
    args.repeats = 3 if args.repeats is None else args.repeats
    if args.camera:
        size = parse_size(args.camera)
        if size is None:
            ap.error(f"--camera {args.camera!r}: give WIDTHxHEIGHT, e.g. 128x128")
        out = args.data_out or data / "camera_step_profile.json"
        return camera_profile(size, 600 if args.steps is None else args.steps, args.repeats, out)
    args.steps = 3000 if args.steps is None else args.steps
    if args.people:
        return people_profile(args.steps, args.repeats, args.data_out or data / "busy_step_profile.json")
    args.data_out = args.data_out or data / "step_profile.json"

    nav = gym.make("BioVLN-OpFace-v0", split="ms_val", obs_mode="state", **CPU)
    cube_id = maniskill_task_id("PickCube")  # PickCube-v1 on ManiSkill 3 (ManiSkill 4 announces -v4)
    cube = gym.make(cube_id, obs_mode="state", **CPU)
    nav.reset(seed=0, options={"episode_index": 0})
    cube.reset(seed=0)
    _run(nav, 50), _run(cube, 50)  # warm-up
    nav_s, cube_s = [], []
    for r in range(args.repeats):  # interleaved, so a busy moment costs both
        nav_s.append(_run(nav, args.steps, r))
        cube_s.append(_run(cube, args.steps, r))
    nav_rate, cube_rate = args.steps / min(nav_s), args.steps / min(cube_s)

    u = nav.unwrapped
    spent = _parts(nav)
    total = _run(nav, args.steps, 99, spent)
    per_step = {k: 1e3 * v / args.steps for k, v in spent.items()}
    rows = share_rows(per_step, 1e3 * total / args.steps)
    notes = [
        f"State-only steps/s, best of {args.repeats} interleaved blocks of {args.steps}: BioVLN-OpFace-v0 "
        f"{nav_rate:.0f}, ManiSkill {cube_id} {cube_rate:.0f} ({nav_rate / cube_rate:.2f}x).",
        f"A control step is {u.sim_freq // u.control_freq} physics substeps (sim {u.sim_freq} Hz, control "
        f"{u.control_freq} Hz); the parts are timed in a block of their own, with the wrappers in place.",
    ]
    print(notes[0])
    write_table(args.data_out, "Where a state-only step spends its time", ["part", "ms per step", "share"],
                rows, notes)  # fmt: skip
    nav.close()
    cube.close()


if __name__ == "__main__":
    main()
