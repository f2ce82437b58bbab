"""Load a Stable-Baselines3 ``model.zip`` without running code from it.

``Algo.load`` unpickles (cloudpickle) every ``:serialized:`` value of the zip's ``data`` JSON, so a crafted
checkpoint runs code. Here nothing is unpickled: the zip is read with limits; each pickled value is only
inspected (the globals its opcodes would import) and refused unless they are ones SB3 itself writes; what
SB3 needs is rebuilt from the plain JSON fields beside it (observation and action space, policy kwargs,
constant clip ranges; the learning-rate schedule is a constant from ``learning_rate``), the rest (last
observations, episode buffers, buffer and policy classes) is dropped; tensors come from
``torch.load(weights_only=True)`` and go into a freshly built model through ``set_parameters``.
"""

from __future__ import annotations

import base64
import json
import math
import pickletools
import re
import zipfile
import zlib
from collections.abc import Callable
from io import BytesIO
from pathlib import Path, PurePosixPath
from typing import Any

import numpy as np
import torch as th
from gymnasium import spaces
from stable_baselines3.common.base_class import BaseAlgorithm
from stable_baselines3.common.save_util import recursive_getattr
from stable_baselines3.common.torch_layers import FlattenExtractor

from biovln_ms.errors import BioVLNError
from biovln_ms.learning.algorithms import SB3_CONTROL_MODES, algo_class

MAX_TOTAL_BYTES = 512 * 2**20  # uncompressed, all entries
MAX_ENTRIES = 64
MAX_WIDTH = 4096  # observation and action size, ints in policy_kwargs (layer widths)
MAX_BUFFER_VALUES = 2**28  # transitions x observation size of the rollout / replay buffer the model allocates
#: weights of the networks the model builds (actor, critics and target critics together; float32: 64 MiB),
#: counted from policy_kwargs before any is allocated
MAX_PARAMETERS = 2**24

# Classes policy_kwargs may name (SB3 writes them as str(cls) beside the pickle).
_KWARG_CLASSES = (
    th.nn.ReLU,
    th.nn.Tanh,
    th.nn.ELU,
    th.nn.LeakyReLU,
    th.nn.SiLU,
    th.nn.GELU,
    th.optim.Adam,
    th.optim.AdamW,
    th.optim.RMSprop,
    th.optim.SGD,
    FlattenExtractor,
)
_CLASS_BY_REPR = {str(c): c for c in _KWARG_CLASSES}
# Globals the pickled values of a model saved by SB3 2.x reference (never imported here: they only tell an
# SB3-written value from a payload).
_SB3_GLOBALS = {
    ("collections", "deque"),
    ("numpy", "dtype"),
    ("numpy", "ndarray"),
    *((f"numpy.{core}.multiarray", n) for core in ("core", "_core") for n in ("scalar", "_reconstruct")),
    *((f"numpy.{core}.numeric", "_frombuffer") for core in ("core", "_core")),
    ("numpy.random._pcg64", "PCG64"),
    ("numpy.random._pickle", "__bit_generator_ctor"),
    ("numpy.random._pickle", "__generator_ctor"),
    ("numpy.random.bit_generator", "SeedSequence"),
    ("numpy.random.bit_generator", "__pyx_unpickle_SeedSequence"),
    ("gymnasium.spaces.box", "Box"),
    ("gymnasium.spaces.discrete", "Discrete"),
    *(
        ("stable_baselines3.common.buffers", n)
        for n in ("RolloutBuffer", "ReplayBuffer", "NStepReplayBuffer")
    ),
    ("stable_baselines3.common.policies", "ActorCriticPolicy"),
    ("stable_baselines3.sac.policies", "SACPolicy"),
    *(("stable_baselines3.common.type_aliases", n) for n in ("TrainFreq", "TrainFrequencyUnit")),
    *(("stable_baselines3.common.utils", n) for n in ("FloatSchedule", "ConstantSchedule")),
    *((c.__module__, c.__qualname__) for c in _KWARG_CLASSES),
}
_BOX, _DISCRETE = str(spaces.Box), str(spaces.Discrete)
_DTYPES = {
    "float16",
    "float32",
    "float64",
    "int8",
    "int16",
    "int32",
    "int64",
    "uint8",
    "uint16",
    "uint32",
    "uint64",
}
_STRING_OPS = {
    "SHORT_BINUNICODE",
    "BINUNICODE",
    "BINUNICODE8",
    "UNICODE",
    "SHORT_BINSTRING",
    "BINSTRING",
    "STRING",
}
_PUT_OPS, _GET_OPS = {"PUT", "BINPUT", "LONG_BINPUT"}, {"GET", "BINGET", "LONG_BINGET"}
_CONSTANT = re.compile(r"ConstantSchedule\(val=([^()]+)\)")
_Refusal = Callable[..., BioVLNError]  # (message, field[, fix]) -> the error to raise


def load_sb3_model(path: str | Path, algo: str, device: str = "cpu") -> BaseAlgorithm:
    """The PPO / A2C / SAC model saved at ``path``, built without unpickling anything from it.

    Raises BioVLNError (source=path) for a file that is not such a model or that carries a pickle which
    would import anything SB3 does not write itself."""
    cls = algo_class(algo)
    path = Path(path)

    def refuse(message: str, field: str = "checkpoint", fix: str | None = None) -> BioVLNError:
        return BioVLNError(
            message,
            source=str(path),
            field=field,
            fix=fix or f"pass the model.zip written by `biovln-ms train {algo}`, with --method {algo}",
        )

    def not_a_model(reason: str, field: str = "checkpoint") -> BioVLNError:
        return refuse(f"not a Stable-Baselines3 {algo.upper()} model: {reason}", field)

    entries = _read_zip(path, not_a_model, refuse)
    if "data" not in entries:
        raise not_a_model("no 'data' entry")
    data = _read_data(entries.pop("data"), not_a_model, refuse)
    tensors = {name.removesuffix(".pth"): _load_tensors(blob, name, refuse) for name, blob in entries.items()}
    variables = tensors.pop("pytorch_variables", None) or {}
    if not isinstance(variables, dict):
        raise not_a_model("pytorch_variables.pth does not hold a dict", "pytorch_variables.pth")

    model = cls("MlpPolicy", env=None, device=device, _init_setup_model=False)
    model.n_envs = 1
    settable = (set(vars(model)) | {"n_envs"}) - set(model._excluded_save_params()) - {"policy_kwargs"}
    for key, value in data.items():
        if key in settable and not _pickled(value):
            setattr(model, key, value)
        elif key in settable and (constant := _constant(value)) is not None:
            setattr(model, key, constant)
    model.policy_kwargs = _policy_kwargs(data.get("policy_kwargs", {}), refuse)
    model.observation_space = _space(data.get("observation_space"))
    if model.observation_space is None:
        model.observation_space = _observation_space_of(tensors.get("policy"), not_a_model)
    model.action_space = _space(data.get("action_space"))
    if (
        model.action_space is None
    ):  # the RL env's (BioVLNNavEnv's) action space of this algorithm's control mode
        model.action_space = (
            spaces.Discrete(4)
            if SB3_CONTROL_MODES[algo] == "discrete"
            else spaces.Box(-1.0, 1.0, (3,), np.float32)
        )
    _check_buffer(model, not_a_model)
    _check_parameters(model, algo, not_a_model)
    try:
        model._setup_model()
    except Exception as e:  # noqa: BLE001 - plain JSON of the wrong type fails in many ways inside SB3
        raise not_a_model(f"its settings do not build one ({_brief(e)})") from None

    state_names, variable_names = model._get_torch_save_params()
    if set(tensors) != set(state_names):
        raise not_a_model(f"it holds {sorted(tensors)}, one has {sorted(state_names)}")
    try:
        model.set_parameters(tensors, exact_match=True, device=device)
    except Exception as e:  # noqa: BLE001 - load_state_dict raises RuntimeError, KeyError, ValueError, ...
        raise not_a_model(f"its weights do not fit ({_brief(e)})") from None
    for name in variable_names:
        value, target = variables.get(name), recursive_getattr(model, name)
        if value is None:
            continue
        if not isinstance(value, th.Tensor) or value.shape != target.shape or value.dtype != target.dtype:
            raise not_a_model(f"'{name}' does not fit", "pytorch_variables.pth")
        target.data = value.data.to(target.device)
    if model.use_sde:
        model.policy.reset_noise()
    return model


def _read_zip(path: Path, not_a_model: _Refusal, refuse: _Refusal) -> dict[str, bytes]:
    """The ``data`` and ``*.pth`` entries, once the archive's size, entry count and names pass."""
    if not zipfile.is_zipfile(path):
        raise not_a_model("not a zip file (or a truncated one)")
    try:
        with zipfile.ZipFile(path) as zf:
            infos = zf.infolist()
            if len(infos) > MAX_ENTRIES:
                raise refuse(f"{len(infos)} entries in the zip, at most {MAX_ENTRIES} are read")
            if sum(i.file_size for i in infos) > MAX_TOTAL_BYTES:
                raise refuse(
                    f"the zip unpacks to {sum(i.file_size for i in infos) / 2**20:.0f} MB, "
                    f"at most {MAX_TOTAL_BYTES // 2**20} MB are read"
                )
            if infos and min(i.header_offset for i in infos) != 0:
                raise not_a_model(
                    "the zip does not start where the file does (truncated, or data put before it)"
                )
            if len({i.filename for i in infos}) != len(infos):
                raise refuse("the zip holds two entries of the same name")
            for i in infos:
                p = PurePosixPath(i.filename.replace("\\", "/"))
                if p.is_absolute() or ".." in p.parts or re.match(r"[A-Za-z]:", i.filename):
                    raise refuse(f"entry '{i.filename}' points outside the archive", i.filename)
            return {
                i.filename: _read_entry(zf, i)
                for i in infos
                if i.filename == "data" or i.filename.endswith(".pth")
            }
    except (
        zipfile.BadZipFile,
        zipfile.LargeZipFile,
        NotImplementedError,
        RuntimeError,
        EOFError,
        OSError,
        zlib.error,
        UnicodeDecodeError,  # an entry name flagged UTF-8 that is not
    ) as e:
        raise not_a_model(f"unreadable zip ({_brief(e)})") from None


def _read_entry(zf: zipfile.ZipFile, info: zipfile.ZipInfo) -> bytes:
    with zf.open(info) as f:
        blob = f.read(info.file_size + 1)  # never more than the size the entry declares (+1 to notice)
    if len(blob) != info.file_size:
        raise zipfile.BadZipFile(f"entry '{info.filename}' is not the size it declares")
    return blob


def _read_data(blob: bytes, not_a_model: _Refusal, refuse: _Refusal) -> dict[str, Any]:
    """The ``data`` JSON, after checking that every pickled value references only what SB3 writes."""
    try:
        data = json.loads(blob)
    except (ValueError, RecursionError):
        raise not_a_model("its 'data' entry is not JSON", "data") from None
    if not isinstance(data, dict):
        raise not_a_model("its 'data' entry is not a JSON object", "data")
    for key, value in data.items():
        if not _pickled(value):
            continue
        try:
            found = pickled_globals(base64.b64decode(value[":serialized:"], validate=True))
        except (ValueError, TypeError):
            raise refuse("a ':serialized:' value that is not a base64 pickle", f"data.{key}") from None
        foreign = sorted(found - _SB3_GLOBALS)
        if foreign:
            raise refuse(
                f"the pickled value would import {'.'.join(foreign[0])}, a checkpoint may not run code",
                f"data.{key}",
                "load only models written by `biovln-ms train`; this loader never unpickles",
            )
    return data


def pickled_globals(blob: bytes) -> set[tuple[str, str]]:
    """Every (module, name) a pickle would import, read from its opcodes without unpickling it.

    A global named indirectly (a computed STACK_GLOBAL operand, an extension code, a persistent id) is
    reported as ``("?", opcode)``: the stack is tracked just enough to know the two strings under a
    STACK_GLOBAL, and any other opcode hides what lies beneath it."""
    found: set[tuple[str, str]] = set()
    stack: list[str | None] = []  # per stack-changing opcode: the string it pushed, else None
    memo: dict[int, str | None] = {}
    for op, arg, _ in pickletools.genops(blob):
        name = op.name
        if name in _STRING_OPS:
            stack.append(arg)
        elif name == "MEMOIZE":
            memo[len(memo)] = stack[-1] if stack else None
        elif name in _PUT_OPS:
            memo[arg] = stack[-1] if stack else None
        elif name in _GET_OPS:
            stack.append(memo.get(arg))
        elif name in ("PROTO", "FRAME", "STOP"):
            continue
        else:
            if name in ("GLOBAL", "INST"):
                found.add(tuple(arg.split(" ", 1)))
            elif name == "STACK_GLOBAL":
                pair = tuple(stack[-2:])
                found.add(pair if len(pair) == 2 and all(isinstance(s, str) for s in pair) else ("?", name))
            elif name in ("EXT1", "EXT2", "EXT4", "PERSID", "BINPERSID"):
                found.add(("?", name))
            stack.append(None)
    return found


def _load_tensors(blob: bytes, name: str, refuse: _Refusal) -> Any:
    try:
        return th.load(BytesIO(blob), map_location="cpu", weights_only=True)
    except Exception as e:  # noqa: BLE001 - the weights-only unpickler raises UnpicklingError, RuntimeError, ...
        raise refuse(
            f"not a weights-only tensor file ({_brief(e)})",
            name,
            "load only models written by `biovln-ms train`; tensors load with weights_only=True",
        ) from None


def _brief(e: Exception) -> str:
    """The exception's type and first 120 characters, on one line."""
    return f"{type(e).__name__}: {' '.join(str(e).split())[:120]}"


def _pickled(value: Any) -> bool:
    return isinstance(value, dict) and ":serialized:" in value


def _constant(entry: dict) -> float | None:
    """The value of a pickled ``FloatSchedule(ConstantSchedule(val=x))`` (a clip range), from its plain
    field."""
    m = _CONSTANT.fullmatch(str(entry.get("value_schedule", "")))
    try:
        return float(m.group(1)) if m else None
    except ValueError:
        return None


def _policy_kwargs(entry: Any, refuse: _Refusal) -> dict:
    """policy_kwargs of plain JSON values, where a pickled dict's class values map back only to known
    classes."""
    if _pickled(entry):
        if entry.get(":type:") != str(dict):
            raise refuse("policy_kwargs is not a dict", "data.policy_kwargs")
        entry = {k: v for k, v in entry.items() if not k.startswith(":")}
        for k, v in entry.items():
            if isinstance(v, str) and v.startswith("<") and v not in _CLASS_BY_REPR:
                raise refuse(
                    f"policy_kwargs names {v}, which this loader does not rebuild", f"data.policy_kwargs.{k}"
                )
        entry = {k: _CLASS_BY_REPR.get(v, v) if isinstance(v, str) else v for k, v in entry.items()}
    if not isinstance(entry, dict):
        raise refuse("policy_kwargs is not a dict", "data.policy_kwargs")
    _check_plain(entry, "data.policy_kwargs", refuse)
    return {k: v for k, v in entry.items() if k != "device"}


def _check_plain(value: Any, field: str, refuse: _Refusal, depth: int = 0) -> None:
    """Plain JSON (or a known class), at most 4 levels and 32 items deep, ints up to MAX_WIDTH."""
    if depth > 4 or (isinstance(value, (list, dict)) and len(value) > 32):
        raise refuse("policy_kwargs nest too deep or too wide", field)
    if isinstance(value, dict):
        for k, v in value.items():
            _check_plain(v, f"{field}.{k}", refuse, depth + 1)
    elif isinstance(value, list):
        for i, v in enumerate(value):
            _check_plain(v, f"{field}[{i}]", refuse, depth + 1)
    elif isinstance(value, int) and not isinstance(value, bool) and abs(value) > MAX_WIDTH:
        raise refuse(f"{value} is larger than {MAX_WIDTH}", field)
    elif not (value is None or isinstance(value, (bool, int, float, str)) or value in _KWARG_CLASSES):
        raise refuse(f"{type(value).__name__} is not a plain JSON value", field)


def _space(entry: Any) -> spaces.Box | spaces.Discrete | None:
    """A Box or Discrete from the plain fields SB3 writes beside the pickled space; None where they do not
    describe one (missing, summarised by numpy, too large)."""
    if not isinstance(entry, dict):
        return None
    try:
        if entry.get(":type:") == _DISCRETE:
            n = int(entry["n"])
            return spaces.Discrete(n, start=int(entry.get("start", 0))) if 1 <= n <= MAX_WIDTH else None
        if (
            entry.get(":type:") == _BOX
            and entry.get("dtype") in _DTYPES
            and isinstance(entry.get("_shape"), list)
        ):
            shape = tuple(int(d) for d in entry["_shape"])
            if not shape or min(shape) < 1 or math.prod(shape) > MAX_WIDTH:
                return None
            low, high = (
                np.array(str(entry[k]).replace("[", " ").replace("]", " ").split()) for k in ("low", "high")
            )
            if low.size != math.prod(shape) or high.size != low.size:
                return None
            dtype = np.dtype(entry["dtype"])
            return spaces.Box(
                low.astype(dtype).reshape(shape), high.astype(dtype).reshape(shape), shape, dtype
            )
    except (KeyError, TypeError, ValueError, OverflowError):
        return None
    return None


def _observation_space_of(policy_state: Any, not_a_model: _Refusal) -> spaces.Box:
    """The RL env's observation space (an unbounded float32 state vector), as wide as the policy's first
    layer."""
    width = (
        next((t.shape[1] for t in policy_state.values() if isinstance(t, th.Tensor) and t.ndim == 2), None)
        if isinstance(policy_state, dict)
        else None
    )
    if width is None or not 1 <= width <= MAX_WIDTH:
        raise not_a_model(
            "no observation space in 'data' and none to infer from policy.pth", "data.observation_space"
        )
    return spaces.Box(-np.inf, np.inf, (width,), np.float32)


def _check_buffer(model: BaseAlgorithm, not_a_model: _Refusal) -> None:
    """Refuse sizes that would make SB3 allocate an outsized rollout or replay buffer."""
    sizes = {k: getattr(model, k) for k in ("n_envs", "n_steps", "buffer_size") if hasattr(model, k)}
    for k, v in sizes.items():
        if type(v) is not int or v < 1:
            raise not_a_model(f"{k} must be a positive integer, got {v!r}", f"data.{k}")
    transitions = sizes.get("buffer_size", sizes["n_steps"] * sizes["n_envs"])
    if transitions * math.prod(model.observation_space.shape) > MAX_BUFFER_VALUES:
        raise not_a_model(
            f"its buffer of {transitions} transitions is larger than this loader allows",
            "data.buffer_size" if "buffer_size" in sizes else "data.n_steps",
        )


def _widths(arch: Any, not_a_model: _Refusal) -> list[int]:
    """A list of layer widths, each a positive integer."""
    if not isinstance(arch, list) or any(type(w) is not int or w < 1 for w in arch):
        raise not_a_model(
            f"net_arch {str(arch)[:60]} is not a list of positive layer widths", "data.policy_kwargs.net_arch"
        )
    return arch


def _mlp(n_in: int, widths: list[int]) -> tuple[int, int]:
    """Weights and output width of fully connected layers of ``widths`` on ``n_in`` inputs."""
    count = 0
    for w in widths:
        count += n_in * w + w
        n_in = w
    return count, n_in


def _check_parameters(model: BaseAlgorithm, algo: str, not_a_model: _Refusal) -> None:
    """Refuse an architecture of more than ``MAX_PARAMETERS`` weights, counted from ``policy_kwargs`` the
    way SB3 builds the MLP policy (flattened observations; ``net_arch`` a list of widths, or per network
    ``pi`` / ``vf`` (``qf`` for SAC), SB3's old ``[dict(...)]`` form too), before any tensor exists."""
    kwargs = model.policy_kwargs
    obs = math.prod(model.observation_space.shape)
    space = model.action_space
    act = int(space.n) if isinstance(space, spaces.Discrete) else math.prod(space.shape)
    arch = kwargs.get("net_arch")
    if isinstance(arch, list) and len(arch) == 1 and isinstance(arch[0], dict):
        arch = arch[0]
    second = "qf" if algo == "sac" else "vf"
    if arch is None:
        arch = [256, 256] if algo == "sac" else {"pi": [64, 64], "vf": [64, 64]}
    if isinstance(arch, dict):
        unknown = sorted(set(arch) - {"pi", second})
        if unknown:
            raise not_a_model(
                f"net_arch names '{unknown[0]}', not pi or {second}", "data.policy_kwargs.net_arch"
            )
        pi, other = _widths(arch.get("pi", []), not_a_model), _widths(arch.get(second, []), not_a_model)
    else:
        pi = other = _widths(arch, not_a_model)
    if algo == "sac":
        critics = kwargs.get("n_critics", 2)
        if type(critics) is not int or critics < 1:
            raise not_a_model(
                f"n_critics must be a positive integer, got {critics!r}", "data.policy_kwargs.n_critics"
            )
        actor, last = _mlp(obs, pi)
        q, q_last = _mlp(obs + act, other)
        total = actor + 2 * (last * act + act) + 2 * critics * (q + q_last + 1)  # critics and their targets
    else:
        actor, last = _mlp(obs, pi)
        value, value_last = _mlp(obs, other)
        log_std = act if isinstance(space, spaces.Box) else 0
        total = actor + last * act + act + log_std + value + value_last + 1  # heads and the value
    if total > MAX_PARAMETERS:
        raise not_a_model(
            f"its networks would have {total:,} weights, more than the limit of {MAX_PARAMETERS:,}",
            "data.policy_kwargs.net_arch",
        )
