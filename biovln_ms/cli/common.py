"""What the commands share: the root Typer app every command and group registers on, the method lines of
the help texts, the lighting option, and finding an episode of a dataset by id or scene."""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer

from biovln_ms.eval.methods import METHODS, report_methods

app = typer.Typer(
    help="BioVLN-MS: operational-face navigation to laboratory instruments (SAPIEN / ManiSkill3).",
    no_args_is_help=True,
    pretty_exceptions_enable=False,
)


def _method_line(name: str) -> str:
    """A registered method: name, label, description and what it needs."""
    s = METHODS[name]
    return (
        f"{name:<13} {s.label} — {s.description}"
        + ("; privileged" if s.privileged else "")
        + (f"; runs on {s.env_id}" if s.env_id else "")
    )


def _methods_help() -> str:
    """One line per registered method, in report order."""
    return "\n".join(_method_line(m) for m in report_methods())


_RECORDABLE = ", ".join(m for m in report_methods() if METHODS[m].recordable)  # what `record` can run as is
_LEARNED = ", ".join(m for m in report_methods() if "checkpoint" in METHODS[m].options)


def given_path(value: str | Path) -> Path:
    """A path option's value, refused when empty: ``Path("")`` is the current folder, which nobody means
    by ``--record ''`` (a unset shell variable)."""
    if isinstance(value, Path):
        return value
    if not value.strip():
        raise typer.BadParameter("an empty path would be the current folder: name a file or folder")
    if "\x00" in value:
        raise typer.BadParameter("a path cannot hold a NUL character")
    return Path(value)


def _lighting_option(default: str = "fast"):
    from biovln_ms.render.lighting import LIGHTING

    return typer.Option(
        default,
        "--lighting",
        help=f"Lighting preset: {', '.join(LIGHTING)} (quality: shadowed ceiling lights).",
    )


def _check_lighting(name: str) -> None:
    """A one-line error for an unknown preset before anything is built."""
    from biovln_ms.render.lighting import lighting_preset

    lighting_preset(name)


def _episode_index(
    episodes: list[dict], split: str, episode: Optional[str], scene: Optional[str], alternative: str = ""
) -> int:
    """Position of ``--episode`` (an episode_id; None: the first) of ``--scene`` (None: the first scene
    holding it) among a split's episodes; a miss names the ids there are (and ``alternative``)."""
    from biovln_ms.episodes.dataset import DatasetError

    here = [i for i, e in enumerate(episodes) if scene in (None, e["scene_id"])]
    k = next((i for i in here if episode in (None, episodes[i]["episode_id"])), None)
    if k is None:
        ids = sorted({episodes[i]["episode_id"] for i in here}, key=lambda x: (len(x), x))
        there = f"ids there run '{ids[0]}'..'{ids[-1]}'" if ids else "no episode there"
        raise DatasetError(
            ("no episode" if episode is None else f"no episode '{episode}'")
            + f" in split '{split}'"
            + (f" for scene '{scene}'" if scene else ""),
            field="--episode",
            fix=f"--episode takes an episode_id: {there}{alternative}",
        )
    return k


def _find_episode(root: Path, split: str, episode: Optional[str], scene: Optional[str]) -> tuple[dict, float]:
    from biovln_ms.episodes.dataset import EpisodeDataset

    ds = EpisodeDataset(root, robot=None)  # any robot's: the map is drawn for the dataset's radius
    episodes = list(ds.episodes(split))
    return episodes[_episode_index(episodes, split, episode, scene)], ds.agent_radius
