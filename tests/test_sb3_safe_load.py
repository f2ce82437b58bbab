"""Stable-Baselines3 checkpoints load without running code from them (biovln_ms.learning.sb3_safe)."""

import io
import json
import os
import pickle
import shlex
import subprocess
import sys
import zipfile

import cloudpickle
import gymnasium as gym
import numpy as np
import pytest
import torch
from stable_baselines3 import A2C, PPO, SAC

from biovln_ms.errors import BioVLNError
from biovln_ms.learning import sb3_safe
from biovln_ms.learning.sb3_safe import load_sb3_model, pickled_globals

ALGOS = {
    "ppo": (PPO, {"n_steps": 16, "batch_size": 16, "n_epochs": 1}),
    "a2c": (A2C, {"n_steps": 8}),
    "sac": (SAC, {"learning_starts": 8, "batch_size": 8, "buffer_size": 64}),
}


class StateEnv(gym.Env):
    """The RL env's spaces (a 19-d state; Discrete(4), or Box(-1, 1, (3,)) for SAC), random states,
    8-step episodes."""

    observation_space = gym.spaces.Box(-np.inf, np.inf, (19,), np.float32)

    def __init__(self, continuous: bool) -> None:
        self.action_space = (
            gym.spaces.Box(-1.0, 1.0, (3,), np.float32) if continuous else gym.spaces.Discrete(4)
        )
        self.t = 0

    def reset(self, *, seed=None, options=None):
        super().reset(seed=seed)
        self.t = 0
        return self.np_random.normal(size=19).astype(np.float32), {}

    def step(self, action):
        self.t += 1
        return self.np_random.normal(size=19).astype(np.float32), 0.0, False, self.t >= 8, {}


class Touch:
    """Unpickling this runs ``touch path``."""

    def __init__(self, path) -> None:
        self.path = str(path)

    def __reduce__(self):
        return os.system, (f"touch {shlex.quote(self.path)}",)


@pytest.fixture(scope="module", autouse=True)
def one_torch_thread():
    """Tiny networks: more threads only contend (SAC's updates slow down many-fold on a busy machine)."""
    n = torch.get_num_threads()
    torch.set_num_threads(1)
    yield
    torch.set_num_threads(n)


@pytest.fixture(scope="module")
def models(tmp_path_factory):
    """A tiny trained model.zip per algorithm (it holds SB3's usual pickled values: spaces, schedules,
    buffers)."""
    root = tmp_path_factory.mktemp("sb3")
    out = {}
    for algo, (cls, kw) in ALGOS.items():
        model = cls("MlpPolicy", StateEnv(algo == "sac"), seed=0, device="cpu", **kw)
        model.learn(32)
        model.save(root / f"{algo}.zip")
        out[algo] = root / f"{algo}.zip"
    return out


def rewrite(src, dst, **entries: bytes):
    """A copy of the zip ``src`` with some entries replaced (None: dropped)."""
    with zipfile.ZipFile(src) as zin, zipfile.ZipFile(dst, "w") as zout:
        for name in zin.namelist():
            blob = entries.get(name, zin.read(name))
            if blob is not None:
                zout.writestr(name, blob)
    return dst


def with_data(src, dst, edit):
    data = json.loads(zipfile.ZipFile(src).read("data"))
    edit(data)
    return rewrite(src, dst, data=json.dumps(data).encode())


def predictions(model, n=50):
    obs = np.random.default_rng(1).normal(size=(n, *model.observation_space.shape)).astype(np.float32)
    return model.predict(obs, deterministic=True)[0]


def test_pickled_payload_in_data_is_refused_and_sb3_would_run_it(models, tmp_path):
    marker = tmp_path / "pwned"
    payload = {
        ":type:": "<class 'numpy.ndarray'>",
        ":serialized:": __import__("base64").b64encode(cloudpickle.dumps(Touch(marker))).decode(),
    }
    evil = with_data(models["ppo"], tmp_path / "evil.zip", lambda d: d.update(_last_obs=payload))
    with pytest.raises(BioVLNError, match="would import posix.system") as e:
        load_sb3_model(evil, "ppo")
    assert e.value.source == str(evil) and e.value.field == "data._last_obs" and e.value.fix
    from biovln_ms.baselines.sb3_policy import SB3Policy

    with pytest.raises(BioVLNError, match="may not run code"):
        SB3Policy(str(evil), "ppo")
    assert not marker.exists()
    # the test is real: SB3's own loader runs the payload
    subprocess.run(
        [
            sys.executable,
            "-c",
            "import sys; from stable_baselines3 import PPO; PPO.load(sys.argv[1])",
            str(evil),
        ],
        check=False,
        cwd=tmp_path,
        capture_output=True,
        timeout=120,
        env={**os.environ, "OMP_NUM_THREADS": "1"},
    )
    assert marker.exists()


@pytest.mark.parametrize(
    "dump", [torch.save, lambda obj, f: pickle.dump(obj, f, protocol=2)], ids=["torch.save", "pickle"]
)
def test_pickled_payload_in_policy_pth_is_refused(models, tmp_path, dump):
    marker = tmp_path / "pwned"
    buf = io.BytesIO()
    dump(Touch(marker), buf)
    evil = rewrite(models["ppo"], tmp_path / "evil.zip", **{"policy.pth": buf.getvalue()})
    with pytest.raises(BioVLNError, match="not a weights-only tensor file") as e:
        load_sb3_model(evil, "ppo")
    assert e.value.source == str(evil) and e.value.field == "policy.pth"
    assert not marker.exists()


def test_static_pickle_scan_sees_through_memo_and_refuses_hidden_operands():
    def s(text: str) -> bytes:  # SHORT_BINUNICODE
        return b"\x8c" + bytes([len(text)]) + text.encode()

    memo = (
        b"\x80\x04" + s("posix") + b"\x94" + s("system") + b"\x94" + b"h\x00h\x01\x93."
    )  # BINGET 0, 1, STACK_GLOBAL
    assert pickled_globals(memo) == {("posix", "system")}
    hidden = (
        b"\x80\x04" + s("posix") + s("system") + s("numpy") + s("dtype") + b"00\x93."
    )  # POP POP STACK_GLOBAL
    assert pickled_globals(hidden) == {("?", "STACK_GLOBAL")}


@pytest.mark.parametrize("algo", list(ALGOS))
def test_legitimate_models_predict_like_sb3_load(models, algo):
    ours, theirs = load_sb3_model(models[algo], algo), ALGOS[algo][0].load(models[algo], device="cpu")
    assert np.array_equal(predictions(ours), predictions(theirs))
    assert ours.observation_space == theirs.observation_space and ours.action_space == theirs.action_space
    assert ours.policy_kwargs == theirs.policy_kwargs  # A2C: RMSprop, rebuilt from its name
    for name, state in theirs.get_parameters().items():
        if "optimizer" not in name:
            assert all(torch.equal(v, ours.get_parameters()[name][k]) for k, v in state.items())


def test_spaces_come_from_the_env_spec_without_their_plain_fields(models, tmp_path):
    def strip(d):
        for key in ("observation_space", "action_space"):
            d[key] = {k: v for k, v in d[key].items() if k.startswith(":")}

    for algo in ("ppo", "sac"):
        bare = with_data(models[algo], tmp_path / f"{algo}.zip", strip)
        assert np.array_equal(
            predictions(load_sb3_model(bare, algo)), predictions(load_sb3_model(models[algo], algo))
        )


def junk_zip(tmp_path, entries):
    path = tmp_path / "junk.zip"
    with zipfile.ZipFile(path, "w") as z:
        for name, blob in entries:
            z.writestr(name, blob)
    return path


@pytest.mark.parametrize(
    "case, match",
    [
        ("not_zip", "not a zip file"),
        ("cut_end", "truncated"),
        ("cut_half", "truncated"),
        ("no_data", "no 'data' entry"),
        ("bad_json", "'data' entry is not JSON"),
        ("dotdot", "points outside the archive"),
        ("absolute", "points outside the archive"),
        ("too_many", "entries in the zip"),
        ("too_big", "unpacks to"),
        ("corrupt", "Bad CRC-32"),
        ("huge_net", "larger than 4096"),
        ("wrong_algo", "not a Stable-Baselines3 PPO model"),
    ],
)
def test_junk_files_are_refused_with_one_clear_error(models, tmp_path, monkeypatch, case, match):
    ppo = models["ppo"]
    if case == "not_zip":
        path = tmp_path / "x.zip"
        path.write_bytes(b"junk")
    elif case.startswith("cut"):  # the half ends inside policy.optimizer.pth, itself a zip (torch.save's)
        path = tmp_path / "cut.zip"
        path.write_bytes(ppo.read_bytes()[: -10 if case == "cut_end" else ppo.stat().st_size // 2])
    elif case == "no_data":
        path = rewrite(ppo, tmp_path / "nodata.zip", data=None)
    elif case == "bad_json":
        path = rewrite(ppo, tmp_path / "bad.zip", data=b"{not json")
    elif case == "dotdot":
        path = junk_zip(tmp_path, [("data", "{}"), ("../policy.pth", b"")])
    elif case == "absolute":
        path = junk_zip(tmp_path, [("data", "{}"), ("/etc/policy.pth", b"")])
    elif case == "too_many":
        path = junk_zip(tmp_path, [(f"f{i}", b"") for i in range(65)])
    elif case == "too_big":
        monkeypatch.setattr(sb3_safe, "MAX_TOTAL_BYTES", 1000)
        path = ppo
    elif case == "corrupt":
        path = junk_zip(tmp_path, [("data", '{"a": 1}')])
        path.write_bytes(path.read_bytes().replace(b'{"a": 1}', b'{"a": 2}'))
    elif case == "huge_net":
        path = with_data(ppo, tmp_path / "huge.zip", lambda d: d.update(policy_kwargs={"net_arch": [10**6]}))
    else:
        path = models["sac"]
    with pytest.raises(BioVLNError, match=match) as e:
        load_sb3_model(path, "ppo")
    assert e.value.source == str(path) and e.value.fix and len(str(e.value).splitlines()) == 1
