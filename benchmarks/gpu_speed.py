"""GPU-parallel simulation of BioVLN-OpFace-v0 on ``physx_cuda``, against ManiSkill's PickCube-v1.

    python benchmarks/gpu_speed.py --out DIR [--section all|meta,state,...] [--smoke]

Sections (each in its own try/except; each figure is written to ``DIR/gpu_speed.json`` and the Markdown
table ``DIR/gpu_speed.md`` as soon as it is measured, so a crash or a time-out later leaves what came
before):

* ``meta``: GPU model, driver, versions of Python / torch / sapien / mani_skill / numpy, the Vulkan device,
  and whether SAPIEN's PhysX GPU library is present (SAPIEN downloads it on first use; a GPU machine with
  no network cannot, so every ``physx_cuda`` section is marked blocked without it instead of hanging).
* ``state``: state-only env steps/s (sub-env steps per second) at N = 64 / 256 / 1,024, random moves
  (FORWARD / TURN_LEFT / TURN_RIGHT) as torch tensors on the device; ``state_autoreset`` adds STOP
  (uniform over the four actions) with partial resets of the ended sub-envs (``env_idx``) at N = 256.
* ``rgbd``: RGB-D 128x128 steps/s at N = 64 / 256.
* ``pickcube``: ManiSkill's own PickCube-v1 (state, N = 1,024, its default controller, random actions): the
  reference the table divides by.
* ``equivalence``: 8 episodes of ms_val stepped with the same actions on ``physx_cpu`` (num_envs = 1, one
  after another) and on ``physx_cuda`` (num_envs = 8): 6 driven by the privileged oracle (recorded on the
  CPU), 2 random walks ending in STOP. Pass: success identical, final positions within 1 cm. Run with the
  env's own sim config and with ``sim_config={"spacing": 50}`` (sub-scenes 50 m apart).
* ``render``: batched RGB-D at 128x128 and 640x480 on num_envs = 4: the sensor data has the batch
  dimension, the sub-envs' images differ; a montage goes to ``DIR/render_check.png``.
* ``depth_pack``: the depth-only shader pack (``biovln_ms.render.camera_shaders``) on this machine's
  renderer: depth and segmentation of ``depth+segmentation`` against the minimal pack's
  (``rgb+depth+segmentation``) over one episode's steps with the same actions at 640x480 (physx_cpu,
  num_envs = 1, rendered by the GPU; needs no PhysX GPU library), and both step rates.
* ``noise``: the ``realistic`` noise preset against ``ideal`` at 640x480 RGB-D + segmentation (physx_cpu,
  num_envs = 1, rendered by the GPU; needs no PhysX GPU library): the images' devices, the goal category
  per pixel against the segmentation read on the CPU, the realistic reset frame against the ideal one (the
  same view, noise added), and both step rates.
* ``cpu_ref``: the same env on ``physx_cpu`` (num_envs = 1): state-only, and RGB-D 128x128 rendered by the
  GPU (needs no PhysX GPU library), and PickCube-v1 on the CPU.
* ``ppo``: the GPU training recipe: Stable-Baselines3 PPO on one batched ``BioVLN-OpFace-RL-v0`` of
  ``PPO_ENVS`` sub-envs on ``physx_cuda`` (``RLConfig.sim_backend``, ``BatchedVecEnv``) for
  ``PPO_TIMESTEPS`` steps on the train split, then MS VAL through the harness (CPU workers, as every
  evaluation): steps/s, wall time, SR. Not in ``run_all.sh``'s default order (it needs a call of its own:
  ``bash scripts/gpu/run_all.sh meta,ppo``); its run folder (``model.zip``, TensorBoard logs,
  ``learning_curve.png``) goes to ``DIR/ppo``.
* ``lighting``: the frame cost of the lighting presets, ``quality`` against ``fast`` at
  640x480 and 128x128, as ``benchmarks/lighting.py`` measures it on the CPU: the env on ``physx_cpu``
  (num_envs = 1, rendered by the GPU; needs no PhysX GPU library) turning in place, ms per ``step`` with its
  RGB-D observation, and the head camera's raw SAPIEN frame (update_render + take_picture + read-back).
  Last in ``run_all.sh``'s order, so a run whose budget the others spent skips it: ``bash
  scripts/gpu/run_all.sh meta,lighting`` measures it alone.

``--smoke`` runs every section at tiny sizes on the CPU backend (num_envs = 1, physx_cpu, CPU rendering),
to test this script on a machine without a GPU. ``scripts/gpu/run_all.sh`` runs each section in its own
process under ``timeout`` on a GPU machine.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import platform
import subprocess
import sys
import time
import traceback
from pathlib import Path

import numpy as np

SECTIONS = (
    "meta",
    "state",
    "state_autoreset",
    "rgbd",
    "pickcube",
    "equivalence",
    "render",
    "depth_pack",
    "noise",
    "cpu_ref",
    "lighting",
    "ppo",
)
PPO_ENVS = 256
PPO_TIMESTEPS = 600_000  # twice the CPU recipe's steps (benchmarks/rl_learning.py); untuned on a GPU
PPO_HYPERPARAMS = {"n_steps": 128, "batch_size": 4096}  # 32,768 steps per rollout (18 updates), 8 minibatches
LIGHTING_SIZES = ((640, 480), (128, 128))
LIGHTING_PRESETS = ("fast", "quality")
NEEDS_PHYSX_GPU = ("state", "state_autoreset", "rgbd", "pickcube", "equivalence", "render", "ppo")
ENV_ID = "BioVLN-OpFace-v0"
SPLIT = "ms_val"  # one scene (seed 154), 50 episodes: partial resets never change a sub-env's scene


class Sizes:
    """What each section measures (the issue's sizes, or tiny ones for ``--smoke``)."""

    def __init__(self, smoke: bool) -> None:
        self.smoke = smoke
        self.state_n = (1,) if smoke else (64, 256, 1024)
        self.autoreset_n = (1,) if smoke else (256,)
        self.rgbd_n = (1,) if smoke else (64, 256)
        self.pickcube_n = 1 if smoke else 1024
        self.ppo_n = 1 if smoke else PPO_ENVS  # physx_cpu holds one sub-env
        self.render_n = 1 if smoke else 4
        self.episodes = 2 if smoke else 8
        self.random_walk = 30 if smoke else 120  # moves before the final STOP of a random-walk episode
        self.steps = 10 if smoke else 200  # timed control steps per measurement (at most)
        self.warmup = 2 if smoke else 10
        self.budget_s = 20.0 if smoke else 40.0  # timed seconds per measurement (at most)


# --- output ------------------------------------------------------------------------------------------
class Results:
    """``DIR/gpu_speed.json``, re-read and re-written (atomically) at every figure, plus the Markdown."""

    def __init__(self, out: Path) -> None:
        self.out = out
        out.mkdir(parents=True, exist_ok=True)
        self.path = out / "gpu_speed.json"

    def load(self) -> dict:
        try:
            return json.loads(self.path.read_text())
        except (OSError, ValueError):
            return {}

    def put(self, section: str, key: str | None, value) -> None:
        data = self.load()
        if key is None:
            data[section] = value
        else:
            data.setdefault(section, {})[key] = value
        tmp = self.path.with_suffix(".tmp")
        tmp.write_text(json.dumps(data, indent=1, default=_jsonable))
        tmp.replace(self.path)
        (self.out / "gpu_speed.md").write_text(markdown(data))
        print(f"[gpu_speed] {section}{'/' + key if key else ''}: {_short(value)}", flush=True)


def _jsonable(x):
    if hasattr(x, "tolist"):
        return x.tolist()
    return str(x)


def _short(v) -> str:
    s = json.dumps(v, default=_jsonable)
    return s if len(s) < 300 else s[:300] + "..."


def error_entry(e: BaseException) -> dict:
    tb = traceback.format_exception(type(e), e, e.__traceback__)
    return {"error": f"{type(e).__name__}: {e}".splitlines()[0][:500], "traceback": "".join(tb)[-3000:]}


def guarded(results: Results, section: str, key: str | None, fn, *args, **kwargs):
    """Run one measurement; its figures or its error line go to the results either way."""
    try:
        value = fn(*args, **kwargs)
    except Exception as e:  # noqa: BLE001 - every failure is a result here
        value = error_entry(e)
        traceback.print_exc()
    results.put(section, key, value)
    return value


# --- the machine -------------------------------------------------------------------------------------
def physx_gpu_library() -> tuple[str, Path]:
    """SAPIEN's PhysX version and where ``sapien.physx.enable_gpu`` looks for its GPU library."""
    import sapien

    version = sapien.physx.version()
    return version, Path.home() / ".sapien" / "physx" / version / "libPhysXGpu_64.so"


def physx_gpu_blocker(smoke: bool) -> str | None:
    """Why ``physx_cuda`` cannot run here (None: it can)."""
    if smoke:
        return None
    import torch

    if not torch.cuda.is_available():
        return "no CUDA device visible to torch"
    version, lib = physx_gpu_library()
    if not lib.is_file():
        return (
            f"SAPIEN's PhysX GPU library {lib} is missing: sapien.physx.enable_gpu() would download it "
            f"(physx-precompiled release {version}, linux-so.zip) and this machine has no network; "
            "carry it (scripts/gpu/run_all.sh looks in .physx/) or install it there first"
        )
    return None


def _nvml_used_mib() -> float | None:
    try:
        import pynvml

        pynvml.nvmlInit()
        h = pynvml.nvmlDeviceGetHandleByIndex(0)
        return pynvml.nvmlDeviceGetMemoryInfo(h).used / 2**20
    except Exception:  # noqa: BLE001
        return None


def meta(smoke: bool) -> dict:
    import mani_skill
    import sapien
    import torch

    out = {
        "python": platform.python_version(),
        "torch": torch.__version__,
        "sapien": sapien.__version__,
        "mani_skill": getattr(mani_skill, "__version__", "?"),
        "numpy": np.__version__,
        "cpu": f"{os.cpu_count()} cores ({platform.machine()})",
        "cuda_available": torch.cuda.is_available(),
        "smoke": smoke,
    }
    try:
        import importlib.metadata as md

        out["mani_skill_dist"] = md.version("mani_skill")
        out["sapien_dist"] = md.version("sapien")
    except Exception:  # noqa: BLE001
        pass
    if torch.cuda.is_available():
        p = torch.cuda.get_device_properties(0)
        out["gpu"] = p.name
        out["gpu_memory_gib"] = round(p.total_memory / 2**30, 1)
        out["torch_cuda"] = torch.version.cuda
    try:
        q = subprocess.run(
            ["nvidia-smi", "--query-gpu=name,driver_version,memory.total", "--format=csv,noheader"],
            capture_output=True,
            text=True,
            timeout=20,
        )
        if q.returncode == 0:
            out["nvidia_smi"] = q.stdout.strip()
            out["driver"] = q.stdout.strip().split(",")[1].strip()
    except (OSError, subprocess.TimeoutExpired):
        pass
    version, lib = physx_gpu_library()
    out["physx"] = version
    out["physx_gpu_library"] = str(lib) if lib.is_file() else None
    out["physx_gpu_blocker"] = physx_gpu_blocker(smoke)
    try:
        from biovln_ms.render.sapien_utils import vulkan_device_label

        out["vulkan"] = vulkan_device_label()
    except Exception as e:  # noqa: BLE001
        out["vulkan"] = f"error: {type(e).__name__}: {e}"
    return out


# --- env helpers ---------------------------------------------------------------------------------------
def backend(smoke: bool) -> dict:
    """The sim backend; the render backend is the env's default (SAPIEN's CPU renderer when no CUDA device
    is visible, the GPU's otherwise)."""
    return dict(sim_backend="physx_cpu" if smoke else "physx_cuda")


def make_nav(n: int, obs_mode: str, smoke: bool, size=(128, 128), **kw):
    import gymnasium as gym

    import biovln_ms  # noqa: F401

    w, h = size
    return gym.make(
        ENV_ID,
        num_envs=n,
        split=SPLIT,
        obs_mode=obs_mode,
        camera_width=w,
        camera_height=h,
        **{**backend(smoke), **kw},
    )


def sync() -> None:
    import torch

    if torch.cuda.is_available():
        torch.cuda.synchronize()


def _done(term, trunc):
    import torch

    return torch.as_tensor(term).reshape(-1).bool() | torch.as_tensor(trunc).reshape(-1).bool()


def timed_steps(env, n: int, action, sizes: Sizes, autoreset: bool = False) -> dict:
    """Steps ``env`` (``action()`` gives the batch of actions) for ``sizes.steps`` control steps or
    ``sizes.budget_s`` seconds, after a warm-up; with ``autoreset``, ended sub-envs are reset by
    ``env_idx``."""
    t = time.perf_counter()
    env.reset(seed=0)
    sync()
    reset_s = time.perf_counter() - t
    for _ in range(sizes.warmup):
        env.step(action())
    sync()
    k = resets = 0
    reset_time = 0.0
    t0 = time.perf_counter()
    while k < sizes.steps and time.perf_counter() - t0 < sizes.budget_s:
        _, _, term, trunc, _ = env.step(action())
        k += 1
        if autoreset:
            done = _done(term, trunc)
            if bool(done.any()):
                r = time.perf_counter()
                idx = done.nonzero().reshape(-1)
                env.reset(options={"env_idx": idx})
                reset_time += time.perf_counter() - r
                resets += int(idx.numel())
    sync()
    dt = time.perf_counter() - t0
    out = {
        "num_envs": n,
        "control_steps": k,
        "seconds": round(dt, 3),
        "steps_per_s": round(k * n / dt, 1),  # sub-env steps per second
        "control_steps_per_s": round(k / dt, 2),
        "first_reset_s": round(reset_s, 3),
        "gpu_used_mib": _nvml_used_mib(),
    }
    if autoreset:
        out.update(partial_resets=resets, reset_seconds=round(reset_time, 3))
    return out


def nav_speed(n: int, obs_mode: str, sizes: Sizes, autoreset: bool = False, size=(128, 128), **kw) -> dict:
    import torch

    t = time.perf_counter()
    env = make_nav(n, obs_mode, sizes.smoke, size, **kw)
    make_s = time.perf_counter() - t
    try:
        dev = env.unwrapped.device
        g = torch.Generator(device=dev).manual_seed(0)
        low = 0 if autoreset else 1  # with STOP episodes end and sub-envs are reset
        out = timed_steps(
            env, n, lambda: torch.randint(low, 4, (n,), device=dev, generator=g), sizes, autoreset
        )
        out["make_s"] = round(make_s, 2)
        out["sim_backend"] = env.unwrapped.backend.sim_backend if hasattr(env.unwrapped, "backend") else None
        return out
    finally:
        env.close()


def pickcube_speed(n: int, sizes: Sizes, sim_backend: str | None = None) -> dict:
    import gymnasium as gym
    import mani_skill.envs  # noqa: F401
    import torch

    kw = backend(sizes.smoke) if sim_backend is None else dict(sim_backend=sim_backend)
    if not torch.cuda.is_available():
        kw["render_backend"] = "cpu"
    t = time.perf_counter()
    env = gym.make("PickCube-v1", num_envs=n, obs_mode="state", **kw)
    make_s = time.perf_counter() - t
    try:
        u = env.unwrapped
        dev = u.device
        g = torch.Generator(device=dev).manual_seed(0)
        shape = u.action_space.shape if n > 1 else (1, *u.single_action_space.shape)

        def action():
            return torch.rand(shape, device=dev, generator=g) * 2 - 1

        out = timed_steps(env, n, action, sizes, autoreset=False)
        out.update(make_s=round(make_s, 2), control_mode=u.control_mode)
        return out
    finally:
        env.close()


# --- equivalence ---------------------------------------------------------------------------------------
def cpu_episodes(sizes: Sizes) -> list[dict]:
    """Each episode k < ``sizes.episodes`` of ms_val on physx_cpu: the actions taken (the oracle's for all
    but the last two, a seeded random walk ending in STOP for those), success, final pose, steps."""
    import torch

    from biovln_ms.baselines.oracle import OraclePolicy

    env = make_nav(1, "state", smoke=True)
    u = env.unwrapped
    rng = np.random.default_rng(14)
    out = []
    try:
        for k in range(sizes.episodes):
            obs, info = env.reset(options={"episode_index": k})
            random_walk = k >= sizes.episodes - (1 if sizes.smoke else 2)
            if random_walk:
                plan = [int(a) for a in rng.integers(1, 4, sizes.random_walk)] + [0]
            else:
                policy = OraclePolicy()
                policy.reset(u.episode_info(0, privileged=True))
            actions = []
            for t in range(u.cfg.max_episode_steps):
                a = plan[t] if random_walk else int(policy.act(obs, info))
                actions.append(a)
                obs, _, term, trunc, info = env.step(torch.tensor([a]))
                if bool(_done(term, trunc).any()):
                    break
            pose = u._pose()[0]
            out.append(
                dict(
                    episode_index=k,
                    driver="random walk" if random_walk else "oracle",
                    actions=actions,
                    success=bool(torch.as_tensor(info["success"]).reshape(-1)[0]),
                    pose=[float(x) for x in pose],
                    steps=len(actions),
                )
            )
    finally:
        env.close()
    return out


def batched_replay(cpu: list[dict], sizes: Sizes, **kw) -> dict:
    """The CPU episodes replayed action for action on ``num_envs = len(cpu)`` (physx_cuda), or, in smoke
    mode, one after another on physx_cpu with num_envs = 1 (the same code path as the CPU side)."""
    import torch

    if sizes.smoke:
        rows = []
        for ep in cpu:
            env = make_nav(1, "state", smoke=True, **kw)
            try:
                env.reset(options={"episode_index": ep["episode_index"]})
                info = {}
                for a in ep["actions"]:
                    _, _, term, trunc, info = env.step(torch.tensor([a]))
                    if bool(_done(term, trunc).any()):
                        break
                rows.append((bool(torch.as_tensor(info["success"]).reshape(-1)[0]), env.unwrapped._pose()[0]))
            finally:
                env.close()
        return compare(cpu, rows, episode_indices=[ep["episode_index"] for ep in cpu])
    n = len(cpu)
    env = make_nav(n, "state", smoke=False, **kw)
    try:
        u = env.unwrapped
        env.reset(seed=0)  # sub-env i starts the episode at cursor position i: episode i of ms_val
        got = [int(i) for i in u._episode_index]
        want = [ep["episode_index"] for ep in cpu]
        if got != want:
            raise RuntimeError(f"reset(seed=0) gave sub-envs episodes {got}, expected {want}")
        longest = max(len(ep["actions"]) for ep in cpu)
        done_at = [None] * n
        info = {}
        for t in range(longest):
            a = [ep["actions"][t] if t < len(ep["actions"]) else 0 for ep in cpu]
            _, _, term, trunc, info = env.step(torch.tensor(a, device=u.device))
            d = _done(term, trunc).cpu().numpy()
            for i in np.flatnonzero(d):
                if done_at[i] is None:
                    done_at[i] = t + 1
            if all(x is not None for x in done_at):
                break
        success = torch.as_tensor(info["success"]).reshape(-1).cpu().numpy()
        poses = u._pose()
        rows = [(bool(success[i]), poses[i]) for i in range(n)]
        out = compare(cpu, rows, episode_indices=got)
        out["gpu_done_at"] = done_at
        return out
    finally:
        env.close()


def compare(cpu: list[dict], rows: list[tuple[bool, np.ndarray]], episode_indices: list[int]) -> dict:
    per = []
    for ep, (success, pose) in zip(cpu, rows):
        d = float(np.hypot(*(np.asarray(pose[:2]) - np.asarray(ep["pose"][:2]))))
        dyaw = float(abs((pose[2] - ep["pose"][2] + math.pi) % (2 * math.pi) - math.pi))
        per.append(
            dict(
                episode_index=ep["episode_index"],
                driver=ep["driver"],
                steps=ep["steps"],
                cpu_success=ep["success"],
                batched_success=success,
                position_diff_m=round(d, 5),
                yaw_diff_deg=round(math.degrees(dyaw), 3),
            )
        )
    same_success = all(p["cpu_success"] == p["batched_success"] for p in per)
    max_d = max((p["position_diff_m"] for p in per), default=0.0)
    return dict(
        passed=bool(same_success and max_d <= 0.01),
        success_identical=same_success,
        max_position_diff_m=max_d,
        cpu_successes=sum(p["cpu_success"] for p in per),
        episodes=per,
        episode_indices=episode_indices,
    )


# --- batched rendering ---------------------------------------------------------------------------------
def render_check(results: Results, sizes: Sizes) -> None:
    import torch

    tiles = []
    for w, h in ((128, 128), (640, 480)):
        key = f"{w}x{h}"

        def one(w=w, h=h):
            n = sizes.render_n
            env = make_nav(n, "rgbd", sizes.smoke, (w, h))
            try:
                obs, _ = env.reset(seed=0)
                dev = env.unwrapped.device
                for a in (1, 2, 1):
                    obs, *_ = env.step(torch.full((n,), a, device=dev))
                head = obs["sensor_data"]["head"]
                rgb, depth = head["rgb"], head["depth"]
                out = dict(
                    num_envs=n,
                    rgb_shape=list(rgb.shape),
                    rgb_dtype=str(rgb.dtype),
                    rgb_device=str(rgb.device),
                    depth_shape=list(depth.shape),
                    depth_dtype=str(depth.dtype),
                    batch_dimension=bool(
                        rgb.shape[0] == n and depth.shape[0] == n and tuple(rgb.shape[1:]) == (h, w, 3)
                    ),
                )
                x = rgb.float().reshape(n, -1)
                out["rgb_mean_per_env"] = [round(float(v), 2) for v in x.mean(1)]
                out["rgb_std_per_env"] = [round(float(v), 2) for v in x.std(1)]
                out["not_blank"] = bool((x.std(1) > 1.0).all())
                if n > 1:
                    diff = [float((x[i] - x[0]).abs().mean()) for i in range(1, n)]
                    out["differs_from_env0"] = [round(v, 2) for v in diff]
                    out["sub_envs_differ"] = bool(min(diff) > 0.5)
                t = time.perf_counter()
                k = 0
                g = torch.Generator(device=dev).manual_seed(1)
                while k < 20 and time.perf_counter() - t < sizes.budget_s / 2:
                    env.step(torch.randint(1, 4, (n,), device=dev, generator=g))
                    k += 1
                sync()
                out["steps_per_s"] = round(k * n / (time.perf_counter() - t), 1)
                tiles.append(rgb[:, :, :, :3].cpu().numpy())
                return out
            finally:
                env.close()

        guarded(results, "render", key, one)
    try:
        save_montage(tiles, results.out / "render_check.png")
    except Exception as e:  # noqa: BLE001
        print(f"[gpu_speed] montage: {type(e).__name__}: {e}")


def depth_pack_check(sizes: Sizes) -> dict:
    """The depth-only pack's depth and segmentation against the minimal pack's, frame by frame (same
    episode, same actions), and the step rate of each (physx_cpu, one sub-env, this machine's renderer)."""
    import torch

    actions = [1, 1, 2, 1, 3, 3, 1, 2]
    frames, out = {}, {}
    for mode in ("rgb+depth+segmentation", "depth+segmentation"):
        env = make_nav(1, mode, sizes.smoke, (640, 480), sim_backend="physx_cpu")
        try:
            obs, _ = env.reset(seed=0, options={"episode_index": 3})
            seen = []
            for a in actions:
                head = obs["sensor_data"]["head"]
                seen.append((head["depth"].clone(), head["segmentation"].clone()))
                obs, *_ = env.step(a)
            frames[mode] = seen
            out[f"{mode}_steps_per_s"] = cycled_step_rate(env, actions, sizes)
            out[f"{mode}_shader"] = env.unwrapped._sensors["head"].config.shader_config.shader_pack
        finally:
            env.close()
    ref, new = frames["rgb+depth+segmentation"], frames["depth+segmentation"]
    out["depth_dtype"] = str(new[0][0].dtype)
    out["depth_identical"] = all(torch.equal(a[0], b[0]) for a, b in zip(ref, new))
    out["segmentation_identical"] = all(torch.equal(a[1], b[1]) for a, b in zip(ref, new))
    out["depth_pixels_differing"] = int(sum(int((a[0] != b[0]).sum()) for a, b in zip(ref, new)))
    out["depth_max_diff_mm"] = max(int((a[0].int() - b[0].int()).abs().max()) for a, b in zip(ref, new))
    return out


def noise_check(sizes: Sizes) -> dict:
    """The ``realistic`` preset on this machine's renderer against ``ideal``: the same episode and actions,
    each image's device, ``semantic_category`` against the segmentation's lookup done on the CPU, how much
    noise the realistic reset frame carries, and the step rate and a profile of each (physx_cpu, one
    sub-env)."""
    import torch

    actions = [2, 2, 3, 2, 3, 3, 2, 2]
    reset_frames, out = {}, {}
    for preset in ("ideal", "realistic"):
        env = make_nav(
            1, "rgb+depth+segmentation", sizes.smoke, (640, 480), sim_backend="physx_cpu", noise=preset
        )
        try:
            obs, _ = env.reset(seed=0, options={"episode_index": 3})
            head = obs["sensor_data"]["head"]
            out[f"{preset}_devices"] = {k: str(v.device) for k, v in head.items()} | {
                "semantic_category": str(obs["extra"]["semantic_category"].device)
            }
            # the reset frames: the same pose in both envs (later steps add actuation noise, so other views)
            reset_frames[preset] = (head["rgb"].cpu().clone(), head["depth"].cpu().clone())
            lookup = env.unwrapped._segmentation_lookup.cpu()
            sem_ok = True
            for a in actions:
                seg = obs["sensor_data"]["head"]["segmentation"].cpu().long().clamp(0, len(lookup) - 1)
                sem_ok &= torch.equal(lookup[seg], obs["extra"]["semantic_category"].cpu())
                obs, *_ = env.step(a)
            out[f"{preset}_semantic_category_matches"] = bool(sem_ok)
            out[f"{preset}_steps_per_s"] = cycled_step_rate(env, actions, sizes)
            out[f"{preset}_profile"] = step_profile(env, actions, max(10, sizes.steps // 3))
        finally:
            env.close()
    (rgb_i, depth_i), (rgb_r, depth_r) = reset_frames["ideal"], reset_frames["realistic"]
    out["rgb_mean_abs_diff"] = round(float((rgb_i.float() - rgb_r.float()).abs().mean()), 2)
    out["depth_pixels_changed"] = round(float((depth_i != depth_r).float().mean()), 3)
    return out


def cycled_step_rate(env, actions: list[int], sizes: Sizes) -> float:
    """Steps per second of ``env`` cycling through ``actions``, for ``sizes.steps`` steps or a quarter of
    ``sizes.budget_s``, whichever ends first."""
    t, k = time.perf_counter(), 0
    while k < sizes.steps and time.perf_counter() - t < sizes.budget_s / 4:
        env.step(actions[k % len(actions)])
        k += 1
    sync()
    return round(k / (time.perf_counter() - t), 1)


def step_profile(env, actions: list[int], n: int, top: int = 12) -> list[dict]:
    """cProfile of ``n`` env steps: the ``top`` functions by their own time (ms per step, own and
    cumulative), so that a slow preset says where its time goes."""
    import cProfile
    import pstats

    prof = cProfile.Profile()
    prof.enable()
    for k in range(n):
        env.step(actions[k % len(actions)])
    sync()
    prof.disable()
    stats = pstats.Stats(prof).stats
    rows = sorted(stats.items(), key=lambda kv: -kv[1][2])[:top]
    return [
        {
            "function": f"{Path(f).name}:{line}({name})",
            "own_ms_per_step": round(tt * 1000 / n, 3),
            "cum_ms_per_step": round(ct * 1000 / n, 3),
        }
        for (f, line, name), (_, _, tt, ct, _) in rows
    ]


def save_montage(tiles: list[np.ndarray], path: Path) -> None:
    """One row per resolution (sub-envs side by side), each image scaled to 160 px high."""
    if not tiles:
        return
    from PIL import Image

    rows = []
    for batch in tiles:
        ims = [Image.fromarray(im.astype(np.uint8)) for im in batch]
        ims = [im.resize((max(1, round(im.width * 160 / im.height)), 160)) for im in ims]
        row = Image.new("RGB", (sum(im.width for im in ims), 160))
        x = 0
        for im in ims:
            row.paste(im, (x, 0))
            x += im.width
        rows.append(row)
    out = Image.new("RGB", (max(r.width for r in rows), 160 * len(rows)))
    for i, r in enumerate(rows):
        out.paste(r, (0, 160 * i))
    out.save(path)


# --- lighting presets ----------------------------------------------------------------------------------
def lighting_speed(preset: str, size: tuple[int, int], sizes: Sizes) -> dict:
    """ms per env step (turning in place, RGB-D observation) and per raw head-camera frame of the env on
    ``physx_cpu`` under lighting ``preset`` at ``size``: rendered by the GPU where there is one."""
    import torch

    from biovln_ms.render.sapien_utils import raw_camera_rate

    t = time.perf_counter()
    env = make_nav(1, "rgbd", sizes.smoke, size, lighting=preset, sim_backend="physx_cpu")
    make_s = time.perf_counter() - t
    try:
        dev = env.unwrapped.device
        turn = torch.full((1,), 2, device=dev)  # TURN_LEFT: the robot stays put, the view changes
        out = timed_steps(env, 1, lambda: turn, sizes)
        out.update(
            lighting=preset,
            size=f"{size[0]}x{size[1]}",
            make_s=round(make_s, 2),
            ms_per_step=round(1000 / out["steps_per_s"], 2),
            raw_ms_per_frame=round(1000 / raw_camera_rate(env, max(5, sizes.steps // 4)), 2),
        )
        return out
    finally:
        env.close()


def ppo_recipe(sizes: Sizes, out: Path) -> dict:
    """SB3 PPO on one batched RL env, then MS VAL through the harness (the ``ppo`` section)."""
    from biovln_ms.eval.learned import train_and_evaluate
    from biovln_ms.learning.rl import RLConfig

    smoke = sizes.smoke
    cfg = RLConfig(
        timesteps=128 if smoke else PPO_TIMESTEPS,
        n_envs=sizes.ppo_n,
        sim_backend=backend(smoke)["sim_backend"],
        eval_split=SPLIT,
        eval_episodes=2 if smoke else None,
        hyperparams={"n_steps": 32, "batch_size": 32} if smoke else PPO_HYPERPARAMS,
    )
    r = train_and_evaluate(cfg, out / "ppo", echo=print, progress=False)
    overall = r.eval_summary["overall"]
    return dict(
        num_envs=cfg.n_envs,
        timesteps=r.timesteps,
        train_minutes=round(r.minutes, 2),
        steps_per_s=round(r.steps_per_second, 1),
        train_success_last_100=round(100 * r.final_success_rate, 1),
        ms_val_sr=round(overall["sr"], 1),
        ms_val_episodes=overall["episodes"],
    )


# --- the sections ---------------------------------------------------------------------------------------
def run_section(name: str, results: Results, sizes: Sizes) -> None:
    if name == "meta":
        guarded(results, "meta", None, meta, sizes.smoke)
        return
    if name in NEEDS_PHYSX_GPU:
        try:
            blocker = physx_gpu_blocker(sizes.smoke)
        except Exception as e:  # noqa: BLE001
            blocker = f"{type(e).__name__}: {e}"
        if blocker:
            results.put(name, None, {"blocked": blocker})
            return
    if name == "state":
        for n in sizes.state_n:
            guarded(results, "state", str(n), nav_speed, n, "state", sizes)
    elif name == "state_autoreset":
        for n in sizes.autoreset_n:
            guarded(results, "state_autoreset", str(n), nav_speed, n, "state", sizes, autoreset=True)
    elif name == "rgbd":
        for n in sizes.rgbd_n:
            guarded(results, "rgbd", str(n), nav_speed, n, "rgbd", sizes)
    elif name == "pickcube":
        guarded(results, "pickcube", str(sizes.pickcube_n), pickcube_speed, sizes.pickcube_n, sizes)
    elif name == "equivalence":
        cpu = guarded(results, "equivalence", "cpu_episodes", cpu_episodes, sizes)
        if isinstance(cpu, dict):  # an error entry
            return
        guarded(results, "equivalence", "env_sim_config", batched_replay, cpu, sizes)
        guarded(results, "equivalence", "spacing_50", batched_replay, cpu, sizes, sim_config={"spacing": 50})
    elif name == "render":
        render_check(results, sizes)
    elif name == "depth_pack":
        guarded(results, "depth_pack", "640x480", depth_pack_check, sizes)
    elif name == "noise":
        guarded(results, "noise", "640x480", noise_check, sizes)
    elif name == "cpu_ref":
        cpu = Sizes(smoke=True)
        cpu.steps, cpu.warmup, cpu.budget_s = (10, 2, 10.0) if sizes.smoke else (300, 10, 30.0)
        guarded(results, "cpu_ref", "state_physx_cpu", nav_speed, 1, "state", cpu)
        # RGB-D on physx_cpu: rendered by the GPU where there is one (no PhysX GPU library needed)
        guarded(results, "cpu_ref", "rgbd128_physx_cpu", nav_speed, 1, "rgbd", cpu)
        guarded(results, "cpu_ref", "pickcube_physx_cpu", pickcube_speed, 1, cpu, "physx_cpu")
    elif name == "lighting":
        light = Sizes(smoke=True)
        light.steps, light.warmup, light.budget_s = (6, 2, 10.0) if sizes.smoke else (100, 10, 10.0)
        for w, h in LIGHTING_SIZES:
            for preset in LIGHTING_PRESETS:
                guarded(results, "lighting", f"{preset}_{w}x{h}", lighting_speed, preset, (w, h), light)
    elif name == "ppo":
        guarded(results, "ppo", str(sizes.ppo_n), ppo_recipe, sizes, results.out)
    else:
        raise SystemExit(f"unknown section {name!r}; known: {', '.join(SECTIONS)}")


# --- the Markdown table ----------------------------------------------------------------------------------
def _fig(entry, field="steps_per_s") -> str:
    if not isinstance(entry, dict):
        return "–"
    if "error" in entry:
        return "error: " + entry["error"][:120]
    if "blocked" in entry:
        return "blocked"
    v = entry.get(field)
    return "–" if v is None else f"{v:,.0f}"


def markdown(data: dict) -> str:
    m = data.get("meta", {})
    lines = [
        "# BioVLN-MS on physx_cuda (benchmarks/gpu_speed.py)",
        "",
        f"- GPU: {m.get('gpu', '–')}; driver {m.get('driver', '–')}; Vulkan: {m.get('vulkan', '–')}",
        f"- versions: Python {m.get('python', '–')}, torch {m.get('torch', '–')}, sapien "
        f"{m.get('sapien_dist', m.get('sapien', '–'))}, "
        f"mani_skill {m.get('mani_skill_dist', m.get('mani_skill', '–'))}, "
        f"numpy {m.get('numpy', '–')}, PhysX {m.get('physx', '–')}",
        f"- CPU: {m.get('cpu', '–')}{' — SMOKE RUN (physx_cpu, tiny sizes)' if m.get('smoke') else ''}",
    ]
    if m.get("physx_gpu_blocker"):
        lines.append(f"- **physx_cuda blocked**: {m['physx_gpu_blocker']}")
    lines += [
        "",
        "| measurement | N | steps/s (sub-env steps) | vs PickCube-v1 | notes |",
        "|---|---:|---:|---:|---|",
    ]
    pick = data.get("pickcube", {})
    pick_rate = None
    if isinstance(pick, dict):
        for v in pick.values():
            if isinstance(v, dict) and "steps_per_s" in v:
                pick_rate = v["steps_per_s"]

    cpu_pick = (
        data.get("cpu_ref", {}).get("pickcube_physx_cpu") if isinstance(data.get("cpu_ref"), dict) else None
    )
    cpu_rate = cpu_pick.get("steps_per_s") if isinstance(cpu_pick, dict) else None

    def ratio(e, ref):
        if ref and isinstance(e, dict) and e.get("steps_per_s"):
            return f"{e['steps_per_s'] / ref:.2f}x"
        return "–"

    def rows(section, label, note=""):
        sec = data.get(section)
        if sec is None:
            return
        if "blocked" in sec or "error" in sec:
            lines.append(
                f"| {label} | – | {_fig(sec)} | – | {sec.get('blocked', sec.get('error', ''))[:160]} |"
            )
            return
        for n, e in sec.items():
            extra = note
            if isinstance(e, dict) and "partial_resets" in e:
                extra = f"{e['partial_resets']} partial resets ({e['reset_seconds']} s)"
            if isinstance(e, dict) and "make_s" in e:
                extra += f" make {e['make_s']} s, first reset {e.get('first_reset_s')} s"
            ref = cpu_rate if section == "cpu_ref" else pick_rate  # each backend against its PickCube-v1
            lines.append(f"| {label} | {n} | {_fig(e)} | {ratio(e, ref)} | {extra.strip()} |")

    rows("state", f"{ENV_ID} state-only, random moves")
    rows("state_autoreset", f"{ENV_ID} state-only, random actions incl. STOP, partial resets")
    rows("rgbd", f"{ENV_ID} RGB-D 128x128")
    rows("pickcube", "PickCube-v1 state (reference)")
    rows("cpu_ref", "physx_cpu reference")
    eq = data.get("equivalence")
    if eq:
        lines += ["", "## CPU / GPU equivalence (same episodes, same actions)", ""]
        if "blocked" in eq:
            lines.append(f"blocked: {eq['blocked']}")
        for k in ("env_sim_config", "spacing_50"):
            e = eq.get(k)
            if isinstance(e, dict) and "passed" in e:
                lines.append(
                    f"- {k}: {'PASS' if e['passed'] else 'FAIL'} — "
                    f"success identical {e['success_identical']}, "
                    f"max position difference {e['max_position_diff_m'] * 100:.2f} cm, CPU successes "
                    f"{e['cpu_successes']}/{len(e['episodes'])}"
                )
            elif isinstance(e, dict):
                lines.append(f"- {k}: {_fig(e)}")
        c = eq.get("cpu_episodes")
        if isinstance(c, dict) and "error" in c:
            lines.append(f"- cpu episodes: {_fig(c)}")

    def bullets(section: str, title: str, field: str, line) -> None:
        """A section's entries as a list: ``line(key, entry)`` for a measured entry (one with ``field``),
        its error otherwise, and the section's blocker if it has one."""
        sec = data.get(section)
        if not sec:
            return
        lines.extend(["", f"## {title}", ""])
        if "blocked" in sec:
            lines.append(f"blocked: {sec['blocked']}")
        for k, e in sec.items():
            if isinstance(e, dict) and field in e:
                lines.append(line(k, e))
            elif isinstance(e, dict) and k != "blocked":
                lines.append(f"- {k}: {_fig(e)}")

    bullets(
        "render",
        "Batched rendering",
        "rgb_shape",
        lambda k, e: (
            f"- {k}: rgb {e['rgb_shape']} {e['rgb_dtype']} on {e['rgb_device']}, depth {e['depth_shape']}; "
            f"batch dimension {e['batch_dimension']}, not blank {e['not_blank']}, sub-envs differ "
            f"{e.get('sub_envs_differ', '–')}; {e['steps_per_s']} steps/s"
        ),
    )
    bullets(
        "depth_pack",
        "Depth-only shader pack against the minimal pack (640x480, physx_cpu, N = 1)",
        "depth_identical",
        lambda k, e: (
            f"- {k}: depth identical {e['depth_identical']} ({e['depth_pixels_differing']} pixels differ, "
            f"at most {e['depth_max_diff_mm']} mm; {e['depth_dtype']}), segmentation identical "
            f"{e['segmentation_identical']}; steps/s {e['depth+segmentation_steps_per_s']} against "
            f"{e['rgb+depth+segmentation_steps_per_s']}"
        ),
    )
    bullets(
        "noise",
        "The realistic noise preset against ideal (640x480 RGB-D + segmentation, physx_cpu, N = 1)",
        "realistic_steps_per_s",
        lambda k, e: (
            f"- {k}: images on {e['realistic_devices']}; goal category per pixel matches the segmentation "
            f"(ideal / realistic) {e['ideal_semantic_category_matches']} / "
            f"{e['realistic_semantic_category_matches']}; reset frame: RGB mean |realistic - ideal| "
            f"{e['rgb_mean_abs_diff']} levels, depth pixels changed {e['depth_pixels_changed']:.1%}; "
            f"steps/s {e['realistic_steps_per_s']} against {e['ideal_steps_per_s']}"
        ),
    )
    bullets(
        "ppo",
        "PPO on one batched RL env",
        "ms_val_sr",
        lambda k, e: (
            f"- {e['num_envs']} sub-envs: {e['timesteps']:,} steps in {e['train_minutes']} min "
            f"({e['steps_per_s']:,.0f} steps/s), last-100 training success {e['train_success_last_100']} %; "
            f"MS VAL SR {e['ms_val_sr']} % over {e['ms_val_episodes']} episodes"
        ),
    )
    lt = data.get("lighting")
    if lt:
        lines += [
            "",
            "## Lighting presets (physx_cpu, num_envs = 1, rendered by the GPU)",
            "",
            "| size | preset | ms / env step (RGB-D) | ms / raw frame | vs fast (step / raw) |",
            "|---|---|---:|---:|---:|",
        ]
        for w, h in LIGHTING_SIZES:
            fast = lt.get(f"fast_{w}x{h}")
            for preset in LIGHTING_PRESETS:
                e = lt.get(f"{preset}_{w}x{h}")
                if not (isinstance(e, dict) and "ms_per_step" in e):
                    lines.append(f"| {w}x{h} | {preset} | {_fig(e)} | – | – |")
                    continue
                vs = "–"
                if isinstance(fast, dict) and "ms_per_step" in fast:
                    vs = (
                        f"{e['ms_per_step'] / fast['ms_per_step']:.2f}x / "
                        f"{e['raw_ms_per_frame'] / fast['raw_ms_per_frame']:.2f}x"
                    )
                lines.append(
                    f"| {w}x{h} | {preset} | {e['ms_per_step']:.2f} | {e['raw_ms_per_frame']:.2f} | {vs} |"
                )
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", type=Path, default=Path(os.environ.get("OUT", "outputs/gpu_speed")))
    ap.add_argument(
        "--section", default="all", help=f"all, or a comma-separated list of {', '.join(SECTIONS)}"
    )
    ap.add_argument(
        "--smoke", action="store_true", help="tiny sizes on physx_cpu (num_envs=1): tests the script"
    )
    ap.add_argument(
        "--record-error", metavar="LINE", help="record LINE as the error of --section (run_all.sh)"
    )
    args = ap.parse_args(argv)
    results = Results(args.out)
    names = SECTIONS if args.section == "all" else tuple(s.strip() for s in args.section.split(","))
    if args.record_error:
        for name in names:
            have = results.load().get(name)
            entry = {"error": args.record_error}
            if isinstance(have, dict) and have and "error" not in have and "blocked" not in have:
                have["process"] = entry  # keep what the section wrote before it died
                entry = have
            results.put(name, None, entry)
        return
    sizes = Sizes(args.smoke)
    for name in names:
        t = time.perf_counter()
        try:
            run_section(name, results, sizes)
        except Exception as e:  # noqa: BLE001
            traceback.print_exc()
            results.put(name, "section_error", error_entry(e))
        print(f"[gpu_speed] section {name} took {time.perf_counter() - t:.1f} s", flush=True)
    if args.section == "all":
        print(markdown(results.load()))


if __name__ == "__main__":
    main(sys.argv[1:])
