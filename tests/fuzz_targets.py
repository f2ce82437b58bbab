"""Fuzz targets for every untrusted input: each target mutates a valid input with a seeded RNG and
classifies what the package did with it:

* ``accepted``: it loaded, and the result passed the target's own validity check (finite numbers, ...);
* ``clear``: it was refused with a ``BioVLNError`` (one line naming the file, the field and the fix), or a
  CLI usage error (exit status 2);
* ``other``: anything else (another exception, an invalid result accepted, a traceback): a bug.

``tests/test_fuzz.py`` runs every target for a fixed budget in CI; ``scripts/fuzz_campaign.py`` runs the long
campaign whose counts README reports. A seed always gives the same input.
"""

from __future__ import annotations

import contextlib
import copy
import io
import json
import math
import zipfile
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import yaml

from biovln_ms.errors import BioVLNError

OUTCOMES = ("accepted", "clear", "other")
LEAF_VALUES = (
    float("nan"),
    float("inf"),
    -float("inf"),
    0,
    -1,
    1e308,
    -1e12,
    "",
    "x" * 300,
    None,
    True,
    [],
    {},
    [[[[0]]]],
    2**70,
)


# --- mutations ------------------------------------------------------------------------------------
def _paths(obj, prefix=()):
    """Every path (tuple of keys / indices) in a JSON value, containers included."""
    yield prefix
    if isinstance(obj, dict):
        for k, v in obj.items():
            yield from _paths(v, prefix + (k,))
    elif isinstance(obj, list):
        for i, v in enumerate(obj):
            yield from _paths(v, prefix + (i,))


def mutate_json(obj, rng: np.random.Generator, edits: int | None = None):
    """A copy of ``obj`` with 1-3 edits: a value replaced (NaN, inf, 0, huge, a string, a list, ...), a key
    deleted, a list emptied or blown up, a number nudged, or a type swapped."""
    out = copy.deepcopy(obj)
    for _ in range(edits or int(rng.integers(1, 4))):
        paths = [p for p in _paths(out) if p]
        if not paths:
            return rng.choice(np.array(LEAF_VALUES, dtype=object))
        path = paths[int(rng.integers(len(paths)))]
        parent = out
        for k in path[:-1]:
            parent = parent[k]
        key, value = path[-1], parent[path[-1]]
        op = int(rng.integers(6))
        if op == 0:
            parent[key] = copy.deepcopy(LEAF_VALUES[int(rng.integers(len(LEAF_VALUES)))])
        elif op == 1:
            del parent[key]
        elif op == 2 and isinstance(value, (int, float)) and not isinstance(value, bool):
            parent[key] = value * float(rng.choice([-1.0, 0.0, 1e-9, 1e6])) + float(rng.normal())
        elif op == 3 and isinstance(value, list):
            parent[key] = [] if rng.random() < 0.5 else value * int(rng.integers(2, 50))
        elif op == 4:
            parent[key] = str(value)
        else:
            parent[key] = [value] if rng.random() < 0.5 else {"x": value}
    return out


def mutate_bytes(data: bytes, rng: np.random.Generator) -> bytes:
    """Byte flips, a truncation, inserted junk or a duplicated region."""
    b = bytearray(data)
    op = int(rng.integers(4))
    if op == 0 and b:
        for i in rng.integers(0, len(b), int(rng.integers(1, 9))):
            b[int(i)] = int(rng.integers(256))
    elif op == 1 and b:
        b = b[: int(rng.integers(0, len(b)))]
    elif op == 2:
        at = int(rng.integers(0, len(b) + 1))
        b[at:at] = bytes(rng.integers(0, 256, int(rng.integers(1, 64)), dtype=np.uint8))
    elif b:
        i, j = sorted(int(v) for v in rng.integers(0, len(b), 2))
        b[j:j] = b[i : i + min(j - i, 4096)]
    return bytes(b)


def finite_everywhere(obj) -> bool:
    """Whether every number in a nested value (pydantic models included) is finite."""
    if hasattr(obj, "model_dump"):
        obj = obj.model_dump()
    if isinstance(obj, float):
        return math.isfinite(obj)
    if isinstance(obj, dict):
        return all(finite_everywhere(v) for v in obj.values())
    if isinstance(obj, (list, tuple)):
        return all(finite_everywhere(v) for v in obj)
    return True


# --- targets --------------------------------------------------------------------------------------
@dataclass
class Target:
    """``setup(tmp) -> state`` once; ``run(state, seed, tmp) -> outcome`` per input."""

    name: str
    what: str
    setup: Callable[[Path], object]
    run: Callable[[object, int, Path], str]


def classify(fn: Callable[[], object], check: Callable[[object], bool] = lambda _: True) -> str:
    try:
        result = fn()
    except BioVLNError as e:
        return "clear" if "\n" not in str(e) else "other"
    except Exception:  # noqa: BLE001 - the fuzzer's point: anything else is a finding
        return "other"
    return "accepted" if check(result) else "other"


def _spec_setup(tmp: Path):
    from biovln_ms.scene.generator import generate_scene

    return json.loads(generate_scene("single_room", 154).model_dump_json())


def _spec_dict(state, seed: int, tmp: Path) -> str:
    from biovln_ms.scene.loading import parse_spec
    from biovln_ms.scene.rules import validate_spec

    bad = mutate_json(state, np.random.default_rng(seed))
    return classify(
        lambda: validate_spec(parse_spec(bad if isinstance(bad, dict) else {"x": bad})), finite_everywhere
    )


def _spec_file(state, seed: int, tmp: Path) -> str:
    from biovln_ms.scene.loading import load_spec
    from biovln_ms.scene.rules import validate_spec

    rng = np.random.default_rng(seed)
    raw = json.dumps(state).encode()
    raw = mutate_bytes(raw, rng) if rng.random() < 0.5 else json.dumps(mutate_json(state, rng)).encode()
    path = tmp / f"spec_{seed}.json"
    path.write_bytes(raw)
    try:
        return classify(lambda: validate_spec(load_spec(path), str(path)), finite_everywhere)
    finally:
        path.unlink()


def _sb3_setup(tmp: Path):
    import gymnasium as gym
    from stable_baselines3 import PPO

    class StateEnv(gym.Env):
        observation_space = gym.spaces.Box(-np.inf, np.inf, (19,), np.float32)
        action_space = gym.spaces.Discrete(4)

        def reset(self, *, seed=None, options=None):
            return np.zeros(19, np.float32), {}

        def step(self, action):
            return np.zeros(19, np.float32), 0.0, False, True, {}

    path = tmp / "ppo.zip"
    PPO(
        "MlpPolicy", StateEnv(), n_steps=16, batch_size=16, device="cpu", policy_kwargs={"net_arch": [8]}
    ).save(path)
    with zipfile.ZipFile(path) as z:
        return {n: z.read(n) for n in z.namelist()}


def _sb3_zip(state: dict, seed: int, tmp: Path) -> str:
    from biovln_ms.learning.sb3_safe import load_sb3_model

    rng = np.random.default_rng(seed)
    entries = dict(state)
    name = sorted(entries)[int(rng.integers(len(entries)))]
    if name == "data" and rng.random() < 0.7:
        entries[name] = json.dumps(mutate_json(json.loads(entries[name]), rng)).encode()
    else:
        entries[name] = mutate_bytes(entries[name], rng)
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w") as z:
        for n, data in entries.items():
            z.writestr(n, data)
    raw = mutate_bytes(buf.getvalue(), rng) if rng.random() < 0.3 else buf.getvalue()
    path = tmp / f"model_{seed}.zip"
    path.write_bytes(raw)
    try:
        return classify(lambda: load_sb3_model(path, "ppo"))
    finally:
        path.unlink()


def _bc_setup(tmp: Path):
    import torch

    from biovln_ms.learning.bc import ARCH, BCConfig

    buf = io.BytesIO()
    state = {
        "head.0.weight": torch.zeros(4, 4),
        "head.0.bias": torch.zeros(4),
    }  # small: loading is what's fuzzed
    meta = {"frame_size": [96, 72]}
    torch.save(
        {
            "arch": ARCH,
            "config": json.dumps(BCConfig().__dict__),
            "meta": json.dumps(meta),
            "state_dict": state,
        },
        buf,
    )
    return buf.getvalue()


def _bc_checkpoint(state: bytes, seed: int, tmp: Path) -> str:
    from biovln_ms.learning.bc import load_bc

    path = tmp / f"bc_{seed}.pt"
    path.write_bytes(mutate_bytes(state, np.random.default_rng(seed)))
    try:
        return classify(lambda: load_bc(path))
    finally:
        path.unlink()


#: cheap CLI commands and their options' valid values (the mutator swaps in junk)
CLI_GRAMMAR = {
    ("catalog",): {"--json": None},
    ("scene", "templates"): {},
    ("scene", "generate"): {
        "--template": "single_room",
        "--seed": "3",
        "--require": "centrifuge",
        "-o": "OUT.json",
    },
    ("scene", "validate"): {"": "SPEC"},
    ("scene", "map"): {"": "SPEC", "-o": "OUT.png"},
    ("dataset", "stats"): {"": "NOWHERE"},
    ("layout", "solve"): {"": "REQ"},
}
JUNK = (
    "",
    "-1",
    "1e999",
    "nan",
    "../../etc/passwd",
    "\x00",
    "x" * 500,
    "--seed",
    "[red]x[/]",
    "-o",
    "0",
    "ö",
)


def _cli_setup(tmp: Path):
    from biovln_ms.scene.generator import generate_scene
    from biovln_ms.scene.spec import save_spec

    spec = tmp / "spec.json"
    save_spec(generate_scene("single_room", 154), spec)
    req = tmp / "req.yaml"
    req.write_text("room: {width: 8, depth: 6}\ninstruments:\n  - {category: centrifuge, count: 1}\n")
    return {"SPEC": str(spec), "REQ": str(req), "NOWHERE": str(tmp / "no_dataset")}


def _cli_args(state: dict, seed: int, tmp: Path) -> str:
    from typer.testing import CliRunner

    from biovln_ms.cli import USER_ERRORS, app, user_error_line

    rng = np.random.default_rng(seed)
    cmds = list(CLI_GRAMMAR)
    cmd = cmds[int(rng.integers(len(cmds)))]
    argv = list(cmd)
    for opt, value in CLI_GRAMMAR[cmd].items():
        if rng.random() < 0.2:
            continue  # leave it out
        v = state.get(value, value)
        if v in ("OUT.json", "OUT.png"):
            v = str(tmp / f"out_{seed}{Path(v).suffix}")
        if rng.random() < 0.4:
            v = JUNK[int(rng.integers(len(JUNK)))]
        argv += ([opt] if opt else []) + ([v] if v is not None else [])
    if rng.random() < 0.2:
        argv.insert(int(rng.integers(len(argv) + 1)), JUNK[int(rng.integers(len(JUNK)))])
    with contextlib.chdir(tmp):  # outputs named by junk values land in the scratch folder
        result = CliRunner().invoke(app, argv, catch_exceptions=True)
    if result.exit_code == 0:
        return "accepted"
    if isinstance(result.exception, USER_ERRORS) and "\n" not in user_error_line(result.exception):
        return "clear"  # what biovln_ms.cli.main prints as one line (exit status 2)
    if result.exit_code == 2 and not isinstance(result.exception, Exception):
        return "clear"  # click's usage error: one message and the usage line
    return "other"


#: env keyword arguments and candidate values: a valid one first (the base set), then others, valid or not;
#: ``ABSENT`` leaves the argument out (so a misspelt name is sometimes passed)
ABSENT = object()
ENV_ARGS = {
    "num_envs": (1, 0, -3, 2.5, "2", None, 10**9, True),
    "camera_width": (64, 0, -64, 1e9, float("nan"), "64", 64.5, True, 4096, 4097),
    "camera_height": (48, 0, -1, float("inf"), np.int64(24)),
    "camera_hfov_deg": (79.0, 0, 170, 180, 200, -1, float("nan"), np.float32(58.0)),
    "camera_far": (20.0, 0.0, 0.05, 1e4, float("nan"), "x"),
    "strict_facing_deg": (30.0, 0, 200, float("inf")),
    "forward_step": (0.25, 0.0, -0.25, float("nan"), 1e6, "0.25", 2.0, 2.5),
    "turn_deg": (30.0, 0, -30, float("inf"), 180, 181),
    "success_bonus": (10.0, float("nan"), 0.0, -1.0, 1e300, "10", float("inf")),
    "step_penalty": (0.01, float("inf"), -float("inf"), -0.01, 0.0, None, float("nan")),
    "safety_penalty": (0.05, float("nan"), 1e7, "0.05"),
    "position_scale": (4.0, 0.0, 1e-300, float("nan")),
    "proportional_safety": (False, True, "yes", 1),
    "goal_mode": ("opface", "centroid", "bogus", 3, []),
    "lighting": ("fast", "quality", "bogus", ["fast"]),
    "measures": (("success", "spl"), ("bogus",), "success", ("subgoal_index",), ["success"], ("reachable",)),
    "sensors": (("gps", "compass"), ("bogus",), "gps", ("instruction",), [], ["objectgoal"]),
    "reward_measure": ("nav_reward", "success", "bogus", None),
    "success_measure": ("success", "strict_success", "distance_to_goal", "bogus"),
    "control_mode": ("discrete", "continuous", "teleport", None, ["discrete"]),
    "sim_backend": ("physx_cpu", "cpu", "bogus", "gpu", "cuda:0", 3),
    "render_backend": ("cpu", "sapien_cpu", "none", "vulkan9"),
    "max_episode_steps": (500, 0, -1, float("nan"), 2.5, 10**7, np.int64(50)),
    "obs_mode": ("none", "state", "bogus", 3, "rgb+bogus", "depth+segmentation", "", "rgbd+state"),
    "reward_mode": ("dense", "sparse", "bogus", 1),
    "render_mode": (None, "rgb_array", "bogus", 2),
    "shader_dir": (None, "minimal", "bogus", 1),
    "enable_shadow": (False, True, "yes"),
    "sensor_configs": (
        {},
        {"shader_pack": "default"},
        {"width": 64},
        {"shader_pack": "bogus"},
        3,
        {"head": 1},
    ),
    "human_render_camera_configs": ({}, {"follow": {"width": 64}}, {"fov": 7.0}, {"pose": [0] * 7}, None),
    "sim_config": ({}, {"sim_freq": 200}, {"sim_freq": 99}, {"bogus": 1}, 3, {"spacing": float("nan")}),
    "reconfiguration_freq": (None, 0, 5, -1, "x"),
    "parallel_in_single_scene": (False, True, "x"),
    "forward_stp": (ABSENT, 0.5),
}


def env_kwargs(seed: int) -> dict:
    """The base set of :data:`ENV_ARGS` with 1-3 arguments given another candidate value (seeded)."""
    rng = np.random.default_rng(seed)
    kw = {k: v[0] for k, v in ENV_ARGS.items()}
    for _ in range(int(rng.integers(1, 4))):
        key = list(ENV_ARGS)[int(rng.integers(len(ENV_ARGS)))]
        kw[key] = ENV_ARGS[key][int(rng.integers(len(ENV_ARGS[key])))]
    return {k: v for k, v in kw.items() if v is not ABSENT}


def _sane_config(cfg) -> bool:
    """Whether an accepted config can run: positive finite sizes, a pinhole camera, finite rewards."""
    numbers = ("forward_step", "turn_deg", "camera_hfov_deg", "camera_far", "success_bonus", "position_scale")
    ints = ("camera_width", "camera_height", "max_episode_steps")
    return (
        all(type(getattr(cfg, n)) is float and 0 < getattr(cfg, n) < 1e7 for n in numbers)
        and all(type(getattr(cfg, n)) is int and getattr(cfg, n) > 0 for n in ints)
        and all(
            type(getattr(cfg, n)) is float and 0 <= getattr(cfg, n) < 1e7
            for n in ("step_penalty", "safety_penalty")
        )
        and cfg.camera_hfov_deg < 180
        and cfg.camera_far > 0.05
        and isinstance(cfg.measures, tuple)
        and isinstance(cfg.sensors, tuple)
        and isinstance(cfg.proportional_safety, bool)
    )


def _env_args(state, seed: int, tmp: Path) -> str:
    """The env's argument checks as ``gym.make`` runs them, up to where it would build a scene (CI builds
    real envs from a few accepted sets in tests/test_fuzz.py)."""
    from biovln_ms.tasks.config_checks import task_config
    from biovln_ms.tasks.nav_env import BioVLNNavEnv

    kw = env_kwargs(seed)
    control = kw.pop("control_mode")
    return classify(lambda: task_config(BioVLNNavEnv.config, control, kw), _sane_config)


#: candidate inputs of ``reset`` and ``step`` (valid ones among them)
SEEDS = (
    0,
    7,
    2**32 - 1,
    -1,
    2**32,
    2**70,
    1.5,
    "3",
    np.int64(3),
    np.uint64(2**63),
    np.float64(2.0),
    True,
    [1],
    [1, 2],
    [],
    np.array(3),
    np.array([3]),
    np.array([[3]]),
    float("nan"),
    {},
    None,
)
RESET_OPTIONS = (
    {"episode_index": 1},
    {"episode_id": "2"},
    {"episode_id": "2", "scene_id": "lab_s0_v0"},
    {"env_idx": [0]},
    {"reconfigure": False},
    {"env_idx": np.array([0]), "episode_index": 0},
)
ACTION_SHAPES = ((), (1,), (3,), (1, 3), (2,), (2, 3), (3, 1), (0,), (4,))
ACTION_DTYPES = (np.int64, np.int32, np.uint8, np.float16, np.float32, np.float64, bool, complex, object)


def _env_actions_setup(tmp: Path):
    import gymnasium as gym

    import biovln_ms  # noqa: F401  (registers the envs)

    cpu = dict(sim_backend="physx_cpu", render_backend="cpu", obs_mode="state", reward_mode="dense")
    return {
        mode: gym.make("BioVLN-OpFace-v0", control_mode=mode, **cpu) for mode in ("discrete", "continuous")
    }


def _random_action(rng: np.random.Generator, mode: str):
    """A valid action of ``mode`` in one of the forms users pass, or something else."""
    import torch

    r = rng.random()
    if r < 0.3:
        if mode == "discrete":
            k = int(rng.integers(0, 4))
            return (k, np.int64(k), np.array(k), torch.tensor([k]))[int(rng.integers(4))]
        a = rng.uniform(-1, 1, 3)
        return (a.tolist(), a.astype(np.float32), torch.tensor(a), a[None])[int(rng.integers(4))]
    if r < 0.45:
        return copy.deepcopy(LEAF_VALUES[int(rng.integers(len(LEAF_VALUES)))])
    if r < 0.55:
        base = {"control_mode": mode, "action": 1 if mode == "discrete" else [0.0, 0.0, 0.0]}
        return mutate_json(base, rng) if rng.random() < 0.7 else base
    values = rng.uniform(-1.5, 4.5, ACTION_SHAPES[int(rng.integers(len(ACTION_SHAPES)))])
    if rng.random() < 0.3 and values.size:
        values.flat[int(rng.integers(values.size))] = rng.choice([np.nan, np.inf, -np.inf, 1e300])
    dtype = ACTION_DTYPES[int(rng.integers(len(ACTION_DTYPES)))]
    if np.dtype(dtype).kind in "iu":
        values = np.round(np.nan_to_num(values, posinf=7.0, neginf=-7.0)).clip(0, 100)
    with np.errstate(over="ignore", invalid="ignore"):  # 1e300 as float16, NaN as bool: junk, on purpose
        a = values.astype(dtype)
    return torch.as_tensor(a) if rng.random() < 0.3 and a.dtype.kind in "biuf" else a


def _env_actions(state: dict, seed: int, tmp: Path) -> str:
    """``reset`` seeds and options and ``step`` actions, valid and not, on a discrete and a continuous env: a
    refusal is one line and changes nothing (step count, pose); an accepted input gives finite rewards and
    poses, one step counted per step, and each reset starts at step 0."""
    from biovln_ms.errors import BioVLNError

    rng = np.random.default_rng(seed)
    mode = "discrete" if rng.random() < 0.5 else "continuous"
    env, n = state[mode], len(state[mode].unwrapped.source)
    u = env.unwrapped
    env.reset(options={"episode_index": int(rng.integers(n))})
    for _ in range(int(rng.integers(0, 3))):
        env.step(2 if mode == "discrete" else [0.0, 0.5, -1.0])  # a turn: the episode goes on
    op = int(rng.integers(3))
    if op == 0:
        seed_in = copy.deepcopy(SEEDS[int(rng.integers(len(SEEDS)))])
        call = lambda: env.reset(seed=seed_in)  # noqa: E731
    elif op == 1:
        options = mutate_json(copy.deepcopy(RESET_OPTIONS[int(rng.integers(len(RESET_OPTIONS)))]), rng)
        call = lambda: env.reset(options=options)  # noqa: E731
    else:
        action = _random_action(rng, mode)
        call = lambda: env.step(action)  # noqa: E731
    steps, pose = int(u.elapsed_steps[0]), u.agent.controller.planar_pose().copy()
    try:
        out = call()
    except BioVLNError as e:
        unchanged = int(u.elapsed_steps[0]) == steps and np.array_equal(
            u.agent.controller.planar_pose(), pose
        )
        return "clear" if "\n" not in str(e) and unchanged and u.agent.control_mode == mode else "other"
    except Exception:  # noqa: BLE001 - the fuzzer's point: anything else is a finding
        return "other"
    now = u.agent.controller.planar_pose()
    ok = bool(np.isfinite(now).all()) and u.agent.control_mode == mode
    if op == 2:
        ok = ok and bool(np.isfinite(out[1].cpu().numpy()).all()) and int(u.elapsed_steps[0]) == steps + 1
    else:
        ok = ok and int(u.elapsed_steps[0]) == 0 and 0 <= u._episode_index[0] < n
    return "accepted" if ok else "other"


def _llm_setup(tmp: Path):
    answer = json.dumps({"choice": 1})
    return {
        "id": "x",
        "object": "chat.completion",
        "model": "m",
        "choices": [
            {"index": 0, "finish_reason": "stop", "message": {"role": "assistant", "content": answer}}
        ],
    }


def _llm_response(state: dict, seed: int, tmp: Path) -> str:
    """A chat-completion body as an endpoint might send it, parsed and validated as LLM-Frontier does (the
    client counts every refusal as a failure and falls back; only an escaping exception is a finding)."""
    from biovln_ms.llm.client import _answer, _Failure

    rng = np.random.default_rng(seed)
    body = copy.deepcopy(state)
    if rng.random() < 0.5:  # edit the answer inside the content string
        content = mutate_json({"choice": 1, "why": "nearest"}, rng)
        body["choices"][0]["message"]["content"] = json.dumps(content)
    raw = json.dumps(mutate_json(body, rng) if rng.random() < 0.7 else body).encode()
    raw = mutate_bytes(raw, rng) if rng.random() < 0.3 else raw

    def valid(o: dict) -> bool:
        return (
            isinstance(o.get("choice"), int)
            and not isinstance(o.get("choice"), bool)
            and 0 <= o["choice"] < 3
        )

    try:
        obj = _answer(raw, valid)
    except _Failure:
        return "clear"
    except Exception:  # noqa: BLE001
        return "other"
    return "accepted" if valid(obj) else "other"


DATASET_EPISODES = "ms_val/content/lab_s154_v0.json.gz"


def _dataset_setup(tmp: Path):
    from biovln_ms.splits import FOUR_CATEGORIES
    from biovln_ms.episodes.writer import SplitPlan, write_dataset
    from biovln_ms.scene.generator import generate_scene

    root = tmp / "ds"
    scene = generate_scene("single_room", 154, required_categories=FOUR_CATEGORIES)
    write_dataset(root, [SplitPlan("ms_val", [(scene, 3, False)])], progress=False)
    return {
        "root": root,
        "manifest": (root / "manifest.json").read_bytes(),
        "episodes": (root / DATASET_EPISODES).read_bytes(),
    }


def _dataset(state: dict, seed: int, tmp: Path) -> str:
    """A dataset whose manifest, one episode record or the episode file's bytes were damaged (the manifest's
    hashes rewritten to match, as a careless hand edit would), loaded as the CLI and the env read it."""
    import gzip
    import hashlib

    from biovln_ms.episodes.dataset import EpisodeDataset
    from biovln_ms.episodes.writer import gz_json

    rng = np.random.default_rng(seed)
    root = state["root"]
    manifest, blob = json.loads(state["manifest"]), state["episodes"]
    kind = int(rng.integers(3))
    if kind == 0:
        obj = json.loads(gzip.decompress(blob))
        k = int(rng.integers(len(obj["episodes"])))
        obj["episodes"][k] = mutate_json(obj["episodes"][k], rng)
        blob = gz_json(obj)
    elif kind == 1:
        blob = (
            mutate_bytes(blob, rng)
            if rng.random() < 0.5
            else gzip.compress(mutate_bytes(gzip.decompress(blob), rng))
        )
    digest = hashlib.sha256(blob).hexdigest()
    for split in manifest["splits"].values():
        for entry in split["files"].values():
            entry["sha256"] = digest
    if kind == 2:
        manifest = mutate_json(manifest, rng)
    (root / DATASET_EPISODES).write_bytes(blob)
    (root / "manifest.json").write_text(json.dumps(manifest))

    def load():
        ds = EpisodeDataset(root)
        return [ep for split in ds.split_names() for ep in ds.episodes(split)]

    try:
        return classify(load, finite_everywhere)
    finally:
        (root / DATASET_EPISODES).write_bytes(state["episodes"])
        (root / "manifest.json").write_bytes(state["manifest"])


# --- hand-written data files: name maps, layout requests, protocols ---------------------------------------
_MARK = "@@value@@"  # stands for a value written into the text itself (Python cannot serialise it)
#: a YAML value of eight aliases deep, standing for 10**9 scalars (flow style: valid inside JSON text too)
_LAUGHS = (
    "[&l0 [x, x, x, x, x, x, x, x, x, x], "
    + ", ".join(f"&l{i} [{', '.join([f'*l{i - 1}'] * 10)}]" for i in range(1, 9))
    + "]"
)


def _blow_up(obj: dict, rng: np.random.Generator) -> tuple[dict, str | None]:
    """A structural attack on a mapping: a value nested deep or a billion-value YAML alias tree (the text
    ``_data_file`` writes in place of ``_MARK``), many entries, or a huge or multi-line key or value."""
    out = copy.deepcopy(obj)
    key = sorted(out)[int(rng.integers(len(out)))]
    op = int(rng.integers(5))
    if op == 0:
        out[key] = _MARK
        deep = int(rng.choice([70, 500, 5000, 100_000]))
        return out, "[" * deep + "0" + "]" * deep
    if op == 1:
        n = int(rng.choice([1_000, 25_000]))
        out.update({f"k{i}": out[key] for i in range(n)})
    elif op == 2:
        out["x" * int(rng.choice([300, 100_000]))] = out.pop(key)
    elif op == 3:
        out[f"{key}\n{key}: x\r\x00"] = out.pop(key)
    else:
        size = int(rng.choice([300, 2_000_000, 0]))
        out[key] = "y" * size if size else _MARK
        return out, None if size else _LAUGHS
    return out, None


class _NoAliases(yaml.SafeDumper):
    """Writes a repeated value out in full: an alias is an attack of its own (``_LAUGHS``)."""

    def ignore_aliases(self, data) -> bool:
        return True


def _data_file(obj, rng: np.random.Generator, path: Path, fifo_rate: float = 0.02) -> None:
    """``obj`` mutated and written to ``path`` as YAML or JSON, with some byte edits, some structural
    attacks, and now and then a FIFO or a folder in the file's place."""
    import os

    r = rng.random()
    if r < fifo_rate:
        os.mkfifo(path)
        return
    if r < 2 * fifo_rate:
        path.mkdir()
        return
    bad, value = _blow_up(obj, rng) if rng.random() < 0.15 else (mutate_json(obj, rng), None)
    if rng.random() < 0.5:
        text = json.dumps(bad)
    else:
        text = yaml.dump(bad, Dumper=_NoAliases, allow_unicode=True, width=2**20)
    if value is not None:
        text = text.replace(f'"{_MARK}"', value).replace(_MARK, value)
    raw = text.encode("utf-8", "surrogatepass")
    path.write_bytes(mutate_bytes(raw, rng) if rng.random() < 0.25 else raw)


def _remove(path: Path) -> None:
    import shutil

    if path.is_dir() and not path.is_symlink():
        shutil.rmtree(path)
    else:
        path.unlink(missing_ok=True)


NAME_MAP = {
    "Sterilgard*": "biosafety_cabinet",
    "BSC-2": None,
    "Fridge_02": "incubator",
    "Bench?": "lab_bench",
}


def _name_map(state, seed: int, tmp: Path) -> str:
    from biovln_ms.limits import MAX_NAME_LENGTH, MAX_NAME_MAP_ENTRIES
    from biovln_ms.lsat.name_map import load_name_map

    path = tmp / f"names_{seed}.yaml"
    _data_file(NAME_MAP, np.random.default_rng(seed), path)

    def valid(names) -> bool:
        return 0 < len(names.entries) <= MAX_NAME_MAP_ENTRIES and all(
            0 < len(e.key) <= MAX_NAME_LENGTH and "\n" not in e.key for e in names.entries
        )

    try:
        return classify(lambda: load_name_map(path), valid)
    finally:
        _remove(path)


LAYOUT_REQUEST = {
    "name": "cell_culture",
    "room": {"width": 7.0, "depth": 6.0, "height": 3.0},
    "furniture": {"lab_bench": 1, "lab_table": 1},
    "instruments": [
        {"category": "incubator", "count": 2, "wall": "N"},
        {"category": "biosafety_cabinet", "wall": "S"},
        {"category": "centrifuge"},
    ],
    "seed": 0,
}


def _layout_request(state, seed: int, tmp: Path) -> str:
    """A request file loaded and validated as ``layout solve`` reads it (solving it is the generator's
    work, which the ``cli_args`` target runs)."""
    from biovln_ms.catalog import load_catalog
    from biovln_ms.lsat.layout import load_request

    path = tmp / f"request_{seed}.yaml"
    _data_file(LAYOUT_REQUEST, np.random.default_rng(seed), path)
    cat = load_catalog()

    def valid(req) -> bool:
        return (
            finite_everywhere(req)
            and 3.0 <= req.room.width <= 30.0
            and 3.0 <= req.room.depth <= 30.0
            and all(
                i.category in cat and cat.get(i.category).placement != "furniture" for i in req.instruments
            )
            and 0 <= req.seed < 2**32
        )

    try:
        return classify(lambda: load_request(path), valid)
    finally:
        _remove(path)


PROTOCOL = {
    "id": "fuzz_protocol",
    "name": "Fuzzed protocol",
    "description": "Why these instruments, in this order.",
    "steps": [
        {"category": "refrigerator", "purpose": "take the samples out"},
        {
            "any_order": [
                {"category": "pipette", "purpose": "dose"},
                {"category": "centrifuge", "purpose": "spin"},
            ]
        },
        {"category": "biosafety_cabinet", "purpose": "work sterile"},
    ],
}


def _protocol_file(state, seed: int, tmp: Path) -> str:
    """A protocol folder holding one mutated file (now and then a FIFO or a folder named ``*.json``, or
    more files than the limit), loaded beside the shipped protocols as ``load_protocols`` does."""
    from biovln_ms.catalog import load_catalog
    from biovln_ms.constants import MAX_VISITS, MIN_VISITS
    from biovln_ms.limits import MAX_PROTOCOL_FILES
    from biovln_ms.protocols.library import load_protocols

    rng = np.random.default_rng(seed)
    folder = tmp / f"protocols_{seed}"
    folder.mkdir()
    if rng.random() < 0.005:  # more files than the limit
        for i in range(MAX_PROTOCOL_FILES + 1):
            (folder / f"p{i}.json").write_text("{}")
    else:
        _data_file(PROTOCOL, rng, folder / "mine.json")
    goals = set(load_catalog().goal_categories())

    def valid(lib) -> bool:
        return all(
            MIN_VISITS <= p.k <= MAX_VISITS and set(p.categories()) <= goals and len(p.description) <= 4096
            for p in lib
        )

    try:
        return classify(lambda: load_protocols(extra_dirs=[folder], env=False), valid)
    finally:
        _remove(folder)


# --- eval options ---------------------------------------------------------------------------------------
#: `biovln-ms eval` options and their valid values (None: a flag); OUT, REC, HAND and CKPT become paths in
#: the scratch folder
EVAL_GRAMMAR = {
    "--method": ("oracle", "random", "frontier", "ppo", "bc", "protocol_oracle", "protocol_language"),
    "--split": ("ms_val", "ms_dev", "protocol_val"),
    "--out": ("OUT",),
    "--dataset": ("NOWHERE",),
    "--env": ("BioVLN-OpFace-v0", "BioVLN-Centroid-v0"),
    "--workers": ("1", "2", "16"),
    "--max-episodes": ("1", "3", "1000"),
    "--record": ("REC",),
    "--record-mode": ("full", "trace"),
    "--checkpoint": ("CKPT",),
    "--name": ("run_1", "frontier+realistic", "a.b@c"),
    "--noise": ("ideal", "realistic"),
    "--robot": ("biovln_base", "fetch"),
    "--export-handoff": ("HAND",),
    "--fresh-scene": (None,),
    "--parser": ("rule", "llm"),
}
#: junk values; none absolute, so that an accepted --out stays in the scratch folder
EVAL_JUNK = (*JUNK, "..", "../..", "a/b", ".", "-3", "99999", "1.5", " ", "+x", "@", "\n")


class _Reached(Exception):
    """Raised where a run would start its episodes: every option check has passed; ``sane`` says whether
    what was accepted is."""

    def __init__(self, sane: bool) -> None:
        self.sane = sane


def _eval_options(state, seed: int, tmp: Path) -> str:
    """`biovln-ms eval` with seeded options, valid or junk. Every check runs for real (typer's, the
    config's, the method's preflight, the run folder and its lock); where the run would start its episodes
    the target stops it and checks what was accepted: a run folder inside ``--out``, counts of at least
    one, no empty folder."""
    from unittest import mock

    from typer.testing import CliRunner

    from biovln_ms.cli import USER_ERRORS, app, user_error_line
    from biovln_ms.eval import harness

    rng = np.random.default_rng(seed)
    top = tmp / f"eval_{seed}"
    scratch = top / "a" / "b" / "c"  # a junk "../../etc/passwd" --out stays below ``top``
    scratch.mkdir(parents=True)
    paths = {"OUT": "out", "REC": "rec", "HAND": "handoff", "CKPT": "model.zip", "NOWHERE": "no_dataset"}
    (scratch / "model.zip").write_bytes(b"not a model")
    argv = ["eval"]
    method = EVAL_GRAMMAR["--method"][int(rng.integers(len(EVAL_GRAMMAR["--method"])))]
    own = {"--checkpoint": method in ("ppo", "bc"), "--parser": method == "protocol_language"}
    for opt, values in EVAL_GRAMMAR.items():
        p = 1.0 if opt == "--method" else (0.9 if own[opt] else 0.03) if opt in own else 0.5
        if rng.random() >= p:
            continue
        v = method if opt == "--method" else values[int(rng.integers(len(values)))]
        v = paths.get(v, v)
        if rng.random() < 0.12:
            v = EVAL_JUNK[int(rng.integers(len(EVAL_JUNK)))]
        argv += [opt] + ([] if v is None else [v])
    if rng.random() < 0.05:
        argv.insert(int(rng.integers(1, len(argv) + 1)), EVAL_JUNK[int(rng.integers(len(EVAL_JUNK)))])

    def stop(cfg, *args, **kwargs):  # in the scratch folder, where relative paths are meant
        out, run = Path(cfg.out).resolve(), cfg.run_dir.resolve()
        raise _Reached(
            run.is_relative_to(out)
            and run != out
            and run.is_relative_to(top.resolve())
            and all(v is None or (type(v) is int and v >= 1) for v in (cfg.max_episodes, cfg.workers))
            and all(v is None or str(v).strip() for v in (cfg.record_dir, cfg.handoff_dir))
        )

    try:
        with contextlib.chdir(scratch), mock.patch.object(harness, "_evaluate_locked", stop):
            result = CliRunner().invoke(app, argv, catch_exceptions=True)
    finally:
        _remove(top)
    if isinstance(result.exception, _Reached):
        return "accepted" if result.exception.sane else "other"
    if isinstance(result.exception, USER_ERRORS) and "\n" not in user_error_line(result.exception):
        return "clear"
    if result.exit_code == 2 and not isinstance(result.exception, Exception):
        return "clear"  # click's usage error
    return "other"


TARGETS: dict[str, Target] = {
    t.name: t
    for t in (
        Target("spec_dict", "scene spec objects (parse_spec, validate_spec)", _spec_setup, _spec_dict),
        Target(
            "spec_file",
            "scene spec files (load_spec, validate_spec): bytes and JSON edits",
            _spec_setup,
            _spec_file,
        ),
        Target("dataset", "dataset manifests, episode records and episode files", _dataset_setup, _dataset),
        Target("sb3_zip", "Stable-Baselines3 checkpoints (load_sb3_model)", _sb3_setup, _sb3_zip),
        Target("bc_checkpoint", "BC checkpoints (load_bc)", _bc_setup, _bc_checkpoint),
        Target("cli_args", "CLI arguments of the cheap commands", _cli_setup, _cli_args),
        Target("env_args", "env arguments (gym.make's checks)", lambda tmp: None, _env_args),
        Target(
            "env_actions",
            "env reset seeds and options, step actions",
            _env_actions_setup,
            _env_actions,
        ),
        Target(
            "llm_response",
            "LLM endpoint answers (LLM-Frontier's parser and validator)",
            _llm_setup,
            _llm_response,
        ),
        Target("name_map", "LSAT name maps (load_name_map)", lambda tmp: None, _name_map),
        Target("layout_request", "layout request files (load_request)", lambda tmp: None, _layout_request),
        Target("protocol_file", "protocol folders (load_protocols)", lambda tmp: None, _protocol_file),
        Target("eval_options", "`eval` command-line options", lambda tmp: None, _eval_options),
    )
}
