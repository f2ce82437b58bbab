"""`biovln-ms dataset`: build, inspect, show and export the episode datasets."""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer
from rich.console import Console

from biovln_ms.cli.common import _find_episode, app
from biovln_ms.errors import BioVLNError

dataset_app = typer.Typer(
    help="Build and inspect the episode datasets.\n\nThe paper's Tables 3, 4, 12 and 13.",
    no_args_is_help=True,
)
app.add_typer(dataset_app, name="dataset")


@dataset_app.command("build")
def dataset_build(
    out: Path = typer.Option(Path("data/biovln"), "-o", "--out", help="Dataset folder to (re)write."),
    robot: str = typer.Option(
        "biovln_base", "--robot", help="Robot the scenes and episodes are made for: biovln_base, fetch."
    ),
) -> None:
    """Build the paper's datasets.

    Every scene and episode, deterministically and atomically, for one robot (its footprint radius)."""
    from biovln_ms.splits import paper_splits
    from biovln_ms.episodes.writer import write_dataset
    from biovln_ms.robot_specs import robot_spec

    robot_spec(robot, "--robot")
    m = write_dataset(out, paper_splits(robot), robot=robot)
    for name, s in m["splits"].items():
        note = f"  (missing: {s['missing']})" if s.get("missing") else ""
        typer.echo(f"{name:<14} {len(s['scenes']):>3} scenes {s['episodes']:>5} episodes{note}")
    typer.echo(f"wrote {out}")


@dataset_app.command("stats")
def dataset_stats(
    root: Optional[Path] = typer.Argument(None, help="Dataset folder (default: built on first use)."),
) -> None:
    """Summarise a dataset per split.

    Scenes, episodes, categories and difficulty mix per split (the paper's MS DEV mix beside ours); for the
    protocol splits also K, route lengths and how many instructions needed a spatial relation."""
    from rich.table import Table

    from biovln_ms.splits import PAPER_MS_DEV_DIFFICULTY, dataset_root
    from biovln_ms.episodes.dataset import EpisodeDataset

    root = dataset_root(root)
    ds = EpisodeDataset(root, robot=None)
    table = Table(title=f"{root} (robot {ds.robot}, agent radius {ds.agent_radius} m)")
    for col in (
        "split",
        "scenes",
        "episodes",
        "categories",
        "easy %",
        "medium %",
        "hard %",
        "start fallback",
        "paper",
    ):
        table.add_column(col)
    protocols = Table(title="protocol splits (lab protocols as multi-goal episodes)")
    for col in ("split", "protocols", "episodes", "mean K", "K = 2 / 3 / 4 / 5", "route m: mean (min-max)"):
        protocols.add_column(col)
    protocols.add_column("needing a relation: episodes % (visits %)")
    for name in ds.split_names():
        info = ds.manifest["splits"][name]
        if info.get("missing") and not info["files"]:
            table.add_row(name, "-", "-", "-", "-", "-", "-", "-", f"MISSING: {info['missing']}")
            continue
        st = ds.stats(name)
        d = st["difficulty"]
        paper = (
            ("paper " + " / ".join(f"{v}" for v in PAPER_MS_DEV_DIFFICULTY.values()))
            if name == "ms_dev"
            else ""
        )
        table.add_row(
            name,
            str(st["scenes"]),
            str(st["episodes"]),
            str(len(st["categories"])),
            f"{d['easy']}",
            f"{d['medium']}",
            f"{d['hard']}",
            str(st["start_fallback"]),
            paper,
        )
        if "protocol" in st:
            p, route = st["protocol"], st["protocol"]["route_length"]
            protocols.add_row(
                name,
                str(p["protocols"]),
                str(st["episodes"]),
                f"{p['mean_k']}",
                " / ".join(str(p["k"].get(k, 0)) for k in range(2, 6)),
                f"{route['mean']} ({route['min']}-{route['max']})",
                f"{p['needs_relation']} ({p['relation_visits']})",
            )
    Console(width=160).print(table)
    if protocols.row_count:
        Console(width=160).print(protocols)


@dataset_app.command("show")
def dataset_show(
    root: Optional[Path] = typer.Argument(None, help="Dataset folder (default: built on first use)."),
    split: str = typer.Option("ms_dev", help="Split name."),
    episode: Optional[str] = typer.Option(None, help="episode_id (default: the first episode)."),
    scene: Optional[str] = typer.Option(None, help="scene_id, when ids repeat across scenes."),
    out: Path = typer.Option(Path("episode.png"), "-o", "--out", help="PNG to write."),
) -> None:
    """Draw the map of one episode.

    Navigable islands, start and heading, goal, view points, shortest path."""
    from biovln_ms.splits import dataset_root
    from biovln_ms.episodes.dataset import EpisodeDataset
    from biovln_ms.scene.rules import scene_navigation
    from biovln_ms.scene.topdown import save_map

    root = dataset_root(root)
    ep, radius = _find_episode(root, split, episode, scene)
    spec = EpisodeDataset(root, verify=False, robot=None).spec(ep["scene_id"])
    typer.echo(f"wrote {save_map(spec, out, episode=ep, nav=scene_navigation(spec, radius))}")


DATASET_EXPORT_FORMATS = ("habitat",)


@dataset_app.command("export")
def dataset_export(
    fmt: str = typer.Argument(..., metavar="FORMAT", help=f"One of: {', '.join(DATASET_EXPORT_FORMATS)}."),
    split: str = typer.Option(..., "--split", "-s", help="Split to export."),
    out: Path = typer.Option(..., "-o", "--out", help="Folder to write into."),
    dataset: Optional[Path] = typer.Option(None, help="Dataset folder (default: built on first use)."),
) -> None:
    """Export a split as another tool's dataset.

    habitat: habitat-lab ObjectNav-v1 episodes (Y-up), the scenes as GLB and a habitat-sim scene dataset
    config."""
    from biovln_ms.splits import dataset_root
    from biovln_ms.bridges.habitat import export_habitat
    from biovln_ms.episodes.dataset import EpisodeDataset

    if fmt not in DATASET_EXPORT_FORMATS:
        raise BioVLNError(
            f"unknown export format '{fmt}'",
            field="FORMAT",
            fix=f"use one of: {', '.join(DATASET_EXPORT_FORMATS)}",
        )
    files = export_habitat(EpisodeDataset(dataset_root(dataset), robot=None), split, out)
    typer.echo(f"wrote {files[-1]}, {files[-2]} and {len(files) - 2} scene GLBs")
