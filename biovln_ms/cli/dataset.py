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
    out: Optional[Path] = typer.Option(
        None,
        "-o",
        "--out",
        help="Dataset folder to (re)write (default: data/biovln; needed with --template).",
    ),
    robot: str = typer.Option(
        "biovln_base", "--robot", help="Robot the scenes and episodes are made for: biovln_base, fetch."
    ),
    template: Optional[str] = typer.Option(
        None,
        "--template",
        help="Build one training split of generated scenes of this template instead (biovln-ms list "
        "templates); the benchmark scenes' seeds are skipped.",
    ),
    scenes: Optional[int] = typer.Option(None, "--scenes", help="With --template: scenes in the split."),
    episodes_per_scene: Optional[int] = typer.Option(
        None, "--episodes-per-scene", help="With --template: episodes per scene."
    ),
    seed: Optional[int] = typer.Option(None, "--seed", help="With --template: the first seed (default 0)."),
    workers: Optional[int] = typer.Option(
        None, "--workers", help="With --template: worker processes, or Ray tasks (default: one per core)."
    ),
    ray_address: Optional[str] = typer.Option(
        None,
        "--ray-address",
        help="With --template: run on Ray: 'local' (a local instance), 'auto' or 'ray://host:port'.",
    ),
    split: Optional[str] = typer.Option(
        None, "--split", help="With --template: the split's name (default: train)."
    ),
    force: bool = typer.Option(
        False, "--force", help="Rebuild the paper's datasets even where the folder holds an up-to-date build."
    ),
) -> None:
    """Build the paper's datasets.

    Every scene and episode of the paper's datasets, deterministically and atomically, for one robot (its
    footprint radius); a folder that already holds an up-to-date build (same format, generator versions,
    catalog, robot and splits) is kept, as a rebuild would write the same bytes (--force rebuilds it). With
    --template: one training split of --scenes generated scenes x
    --episodes-per-scene episodes instead, in parallel; the same arguments give the same bytes, a killed
    build resumes where it stopped, and no scene of a benchmark split enters it."""
    from biovln_ms.robot_specs import robot_spec

    robot_spec(robot, "--robot")
    given = {
        "--scenes": scenes,
        "--episodes-per-scene": episodes_per_scene,
        "--seed": seed,
        "--workers": workers,
        "--ray-address": ray_address,
        "--split": split,
    }
    if template is None:
        extra = next((k for k, v in given.items() if v is not None), None)
        if extra:
            raise BioVLNError(
                "builds a training split of generated scenes, which needs --template",
                field=extra,
                fix="add --template NAME (biovln-ms list templates), or drop it for the paper's datasets",
            )
        _build_paper(out or Path("data/biovln"), robot, force)
        return
    if force:
        raise BioVLNError(
            "rebuilds the paper's datasets; a --template build resumes what it finds",
            field="--force",
            fix="drop --force, or remove the --out folder to start the split afresh",
        )
    for name in ("--scenes", "--episodes-per-scene"):
        if given[name] is None:
            raise BioVLNError("needed with --template", field=name, fix=f"add {name} N")
    if out is None:
        raise BioVLNError(
            "needed with --template", field="--out", fix="add -o DIR (a folder of its own: it is rewritten)"
        )
    _build_training(out, robot, template, scenes, episodes_per_scene, seed, workers, ray_address, split)


def _build_paper(out: Path, robot: str, force: bool) -> None:
    from biovln_ms.splits import paper_splits, stale_paper_dataset
    from biovln_ms.episodes.writer import write_dataset

    if not force and stale_paper_dataset(out, robot) is None:
        typer.echo(f"{out} is up to date for {robot} (the same bytes a rebuild writes; --force rebuilds it)")
        return
    m = write_dataset(out, paper_splits(robot), robot=robot)
    for name, s in m["splits"].items():
        note = f"  (missing: {s['missing']})" if s.get("missing") else ""
        typer.echo(f"{name:<14} {len(s['scenes']):>3} scenes {s['episodes']:>5} episodes{note}")
    typer.echo(f"wrote {out}")


def _build_training(
    out, robot, template, scenes, episodes_per_scene, seed, workers, ray_address, split
) -> None:
    import os
    import time

    from biovln_ms.episodes.bulk import build_training_split, check_request
    from biovln_ms.splits import held_out_seeds

    seed = 0 if seed is None else seed
    workers = (os.cpu_count() or 1) if workers is None else workers
    split = "train" if split is None else split
    check_request(scenes, episodes_per_scene, seed, workers, split, ray_address)
    t0 = time.perf_counter()
    m = build_training_split(
        out,
        template,
        scenes,
        episodes_per_scene,
        held_out=held_out_seeds(),
        first_seed=seed,
        workers=workers,
        ray_address=ray_address,
        split=split,
        robot=robot,
        echo=typer.echo,
    )
    s = m["splits"][split]
    seeds = [m["scenes"][name]["seed"] for name in s["scenes"]]
    typer.echo(
        f"{split}: {s['description']}; {s['episodes']:,} episodes, seeds {seeds[0]}-{seeds[-1]}, "
        f"{time.perf_counter() - t0:.0f} s"
    )
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
    busy = Table(title="busy splits (episodes with their own crowd)")
    for col in (
        "split",
        "episodes",
        "people: episodes",
        "mean people",
        "goal face occupied: episodes %",
        "steps %",
    ):
        busy.add_column(col)
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
        if "people" in st:
            p = st["people"]
            busy.add_row(
                name,
                str(st["episodes"]),
                ", ".join(f"{k}: {v}" for k, v in p["count"].items()),
                f"{p['mean_count']}",
                f"{p['occupied_episodes']}",
                f"{p['occupied_steps']}",
            )
    Console(width=160).print(table)
    if protocols.row_count:
        Console(width=160).print(protocols)
    if busy.row_count:
        Console(width=160).print(busy)


@dataset_app.command("show")
def dataset_show(
    root: Optional[Path] = typer.Argument(None, help="Dataset folder (default: built on first use)."),
    split: str = typer.Option("ms_dev", help="Split name."),
    episode: Optional[str] = typer.Option(None, help="episode_id (default: the first episode)."),
    scene: Optional[str] = typer.Option(None, help="scene_id, when ids repeat across scenes."),
    out: Path = typer.Option(Path("episode.png"), "-o", "--out", help="PNG to write."),
) -> None:
    """Draw the map of one episode.

    Navigable islands, start and heading, goal, view points, shortest path; a busy split's episode also
    its people and the paths they walk over its step limit (the robot standing at its start)."""
    from biovln_ms.splits import busy_step_seconds, dataset_root
    from biovln_ms.episodes.dataset import EpisodeDataset
    from biovln_ms.people.episodes import crowd_paths
    from biovln_ms.scene.rules import scene_navigation
    from biovln_ms.scene.topdown import save_map

    root = dataset_root(root)
    ep, radius = _find_episode(root, split, episode, scene)
    spec = EpisodeDataset(root, verify=False, robot=None).spec(ep["scene_id"])
    nav = scene_navigation(spec, radius)
    people = crowd_paths(spec, nav, ep, busy_step_seconds()) if "people" in ep else None
    typer.echo(f"wrote {save_map(spec, out, episode=ep, nav=nav, people=people)}")


DATASET_EXPORT_FORMATS = ("habitat",)


@dataset_app.command("export")
def dataset_export(
    fmt: str = typer.Argument(..., metavar="FORMAT", help=f"One of: {', '.join(DATASET_EXPORT_FORMATS)}."),
    split: str = typer.Option(..., "--split", "-s", help="Split to export."),
    out: Path = typer.Option(..., "-o", "--out", help="Folder to write into."),
    dataset: Optional[Path] = typer.Option(None, help="Dataset folder (default: built on first use)."),
) -> None:
    """Export a split as another tool's dataset.

    habitat: habitat-lab ObjectNav-v1 episodes (Y-up), each scene as a habitat-sim scene instance (a
    navmesh-safe stage, a render-only overhead object, instance semantics) and a scene dataset config."""
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
    typer.echo(f"wrote {files[-1]}, {files[-2]} and {len(files) - 2} scene files")
