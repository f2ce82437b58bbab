"""One meaning per flag across commands, help texts that are never cut short, and dataset commands that
default to the default dataset. Walks the real typer app, so new commands are checked
too."""

from __future__ import annotations

import inspect
import types
import typing
from collections import defaultdict
from pathlib import Path

import pytest
import typer
from typer.testing import CliRunner

from biovln_ms.cli import app

#: click's default short-help width: shell completion and ``typer utils docs`` cut longer first sentences
#: with "..." (and the plain --help listing, a little wider, does too).
SHORT_HELP = 45

#: flag -> (type of its value, a word its help must hold): the one meaning it has in every command
MEANINGS: dict[str, tuple[type, str]] = {
    "--episode": (str, "episode_id"),
    "--scene": (str, "scene_id"),
    "--index": (int, "Position"),
    "--split": (str, "plit"),
    "--dataset": (Path, "ataset"),
    "--seed": (int, "eed"),
    "--out": (Path, ""),
    "--env": (str, "nv"),
}
#: short flag -> the long flag it stands for, in every command
SHORT: dict[str, str] = {"-o": "--out", "-s": "--split", "-t": "--template", "-m": "--method"}


def _commands(cmd=None, path: tuple[str, ...] = ()):
    """(path, click command) of every command and group below the root."""
    cmd = cmd or typer.main.get_command(app)
    for name, sub in getattr(cmd, "commands", {}).items():
        yield (*path, name), sub
        yield from _commands(sub, (*path, name))


def _value_type(cmd, param) -> type:
    """The Python type of a parameter's value (Optional stripped), from the command's signature."""
    hint = typing.get_type_hints(inspect.unwrap(cmd.callback))[param.name]
    if typing.get_origin(hint) in (typing.Union, types.UnionType):
        (hint,) = [a for a in typing.get_args(hint) if a is not type(None)]
    return hint


def _options():
    """(command path, flag, param, value type) of every option of every command."""
    for path, cmd in _commands():
        if cmd.callback is None:
            continue
        for p in cmd.params:
            if p.param_type_name == "option":
                for flag in (*p.opts, *p.secondary_opts):
                    yield " ".join(path), flag, p, _value_type(cmd, p)


def test_each_flag_has_one_type_across_commands():
    seen: dict[str, dict[type, list[str]]] = defaultdict(lambda: defaultdict(list))
    for where, flag, _, kind in _options():
        seen[flag][kind].append(where)
    mixed = {f: dict(kinds) for f, kinds in seen.items() if len(kinds) > 1}
    assert not mixed, f"flags whose value type differs between commands: {mixed}"


def test_documented_flags_mean_the_same_everywhere():
    for where, flag, p, kind in _options():
        if flag in MEANINGS:
            want, word = MEANINGS[flag]
            assert kind is want, f"`{where} {flag}` takes {kind.__name__}, elsewhere {want.__name__}"
            assert word in (p.help or ""), f"`{where} {flag}` help {p.help!r} does not say {word!r}"


def test_short_flags_stand_for_one_long_flag():
    for where, flag, p, _ in _options():
        if len(flag) == 2:
            assert flag in SHORT, f"`{where}`: new short flag {flag}: add it to SHORT with its one meaning"
            assert SHORT[flag] in p.opts, f"`{where}`: {flag} is {p.opts}, elsewhere {SHORT[flag]}"


def test_help_texts_are_never_cut_short():
    for path, cmd in _commands():
        short = cmd.get_short_help_str(SHORT_HELP)
        assert not short.endswith(("...", "…")), (
            f"`{' '.join(path)}`: first sentence longer than {SHORT_HELP} characters, listed as {short!r}: "
            "start its help with a short sentence, then a blank line and the details"
        )
        texts = [cmd.help or ""] + [p.help or "" for p in cmd.params]
        assert not [t for t in texts if t.rstrip().endswith(("...", "…"))], " ".join(path)


def test_plain_help_listings_are_not_truncated(monkeypatch):
    monkeypatch.setenv("COLUMNS", "80")
    monkeypatch.setattr(typer.core, "HAS_RICH", False)
    for path, cmd in [((), None), *_commands()]:
        if cmd is not None and not hasattr(cmd, "commands"):
            continue
        r = CliRunner().invoke(app, [*path, "--help"])
        listing = r.output.split("Commands:")[-1]
        assert r.exit_code == 0 and "..." not in listing, (path, listing)


@pytest.fixture
def default_dataset(held_out_dataset, monkeypatch) -> str:
    root = held_out_dataset(ms_val=3, ms_dev=2)
    monkeypatch.setenv("BIOVLN_DATA_DIR", root)
    return root


def test_dataset_stats_and_show_default_to_the_default_dataset(default_dataset, tmp_path):
    r = CliRunner().invoke(app, ["dataset", "stats"])
    assert r.exit_code == 0 and default_dataset in " ".join(r.output.split()) and "ms_val" in r.output, (
        r.output
    )
    r = CliRunner().invoke(app, ["dataset", "show", "--split", "ms_val", "-o", str(tmp_path / "e.png")])
    assert r.exit_code == 0 and (tmp_path / "e.png").stat().st_size > 0, r.output


def test_record_takes_an_episode_id_or_an_index(default_dataset):
    from biovln_ms.cli import _record_index
    from biovln_ms.episodes.dataset import DatasetError, EpisodeDataset

    root = Path(default_dataset)
    ids = [e["episode_id"] for e in EpisodeDataset(root).episodes("ms_val")]
    assert _record_index(root, "ms_val", None, None, None) == 0
    assert _record_index(root, "ms_val", ids[2], None, None) == 2
    assert _record_index(root, "ms_val", None, None, 1) == 1
    with pytest.raises(DatasetError) as e:  # an old-style index past the ids: told about --index
        _record_index(root, "ms_val", "7", None, None)
    assert "no episode '7'" in str(e.value) and "--index K" in str(e.value) and "\n" not in str(e.value)
    with pytest.raises(DatasetError, match="out of range"):
        _record_index(root, "ms_val", None, None, 3)
    with pytest.raises(Exception, match="--index and --episode"):
        _record_index(root, "ms_val", "0", None, 0)
