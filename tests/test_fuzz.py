"""The fuzz suite: every untrusted input's target (``tests/fuzz_targets.py``) on a fixed budget of
seeded inputs (``BIOVLN_FUZZ_EXAMPLES``, default 60 per target): each input is accepted correctly or refused
with one clear line, never anything else. ``scripts/fuzz_campaign.py`` runs the long campaign."""

import os

import gymnasium as gym
import pytest

import biovln_ms  # noqa: F401
from fuzz_targets import TARGETS, _env_args, env_kwargs

BUDGET = int(os.environ.get("BIOVLN_FUZZ_EXAMPLES", 60))


@pytest.mark.parametrize("name", sorted(TARGETS))
def test_target_gives_no_other_outcome(name, tmp_path):
    target = TARGETS[name]
    state = target.setup(tmp_path)
    outcomes = [target.run(state, seed, tmp_path) for seed in range(BUDGET)]
    others = [seed for seed, o in enumerate(outcomes) if o == "other"]
    assert not others, f"{name}: seeds {others[:10]} gave neither a correct result nor a clear error"
    assert "clear" in outcomes, f"{name}: no input was refused, so the mutations do not reach the checks"


def test_accepted_env_arguments_really_build_an_env():
    """The env-argument target checks arguments only; a few accepted sets are built for real."""
    built = 0
    for seed in range(400):
        if _env_args(None, seed, None) != "accepted":
            continue
        kw = env_kwargs(seed)
        kw.update(camera_width=32, camera_height=24)  # keep the frames small
        env = gym.make("BioVLN-OpFace-v0", **kw)
        env.reset(seed=0)
        env.step(env.action_space.sample())
        env.close()
        built += 1
        if built == 2:
            break
    assert built == 2


#: inputs the 10,000-per-target campaign (and the first runs of newer targets) found, kept as regression cases
FOUND = {
    "spec_dict": (4993, 9011),  # a spec without walls crashed the flush-wall rule
    "spec_file": (8444,),
    "sb3_zip": (2142, 6994),  # zip entry names flagged UTF-8 that are not
    "cli_args": (190, 232, 1341, 2743),  # unwritable output paths; a negative seed
    "name_map": (142, 195),  # a folder in the file's place (open() of a folder succeeds on Linux)
    "layout_request": (31, 284),  # a key with a line break, quoted as the error's field
    "protocol_file": (60, 163, 168),  # a folder named *.json
}


@pytest.mark.parametrize("name, seed", [(n, s) for n, seeds in FOUND.items() for s in seeds])
def test_campaign_findings_stay_fixed(name, seed, tmp_path):
    target = TARGETS[name]
    assert target.run(target.setup(tmp_path), seed, tmp_path) != "other"
