"""`biovln-ms perception`: the object detector's labelled frames."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Optional

import typer

from biovln_ms.cli.common import app, given_path

perception_app = typer.Typer(
    help="Object detector data.\n\nLabelled frames rendered from the simulator.", no_args_is_help=True
)
app.add_typer(perception_app, name="perception")


@perception_app.command("dataset")
def perception_dataset(
    root: Optional[Path] = typer.Argument(
        None, help="Episode dataset folder (default: the benchmark dataset, built on first use)."
    ),
    out: Path = typer.Option(..., "-o", "--out", help="Folder to (re)write."),
    frames: int = typer.Option(2000, "--frames", help="Frames to render."),
    seed: int = typer.Option(0, "--seed", help="Seed of every random choice: the same seed, the same bytes."),
    split: str = typer.Option("train", "--split", help="The episode split whose scenes and paths are shown."),
    frame_size: str = typer.Option("320x240", "--frame-size", help="WIDTHxHEIGHT of the frames."),
    workers: int = typer.Option(1, "--workers", help="Render processes."),
) -> None:
    """Render labelled detector frames.

    RGB, depth (mm) and instance masks with COCO annotations of the catalog's goal categories, from
    robot-height viewpoints along the split's episode paths; lighting, looks, dressing, camera height and
    image noise drawn from the seed. Held out: a set of the split's scenes (test_scenes) and paint looks
    (test_looks)."""
    from biovln_ms.episodes.dataset import EpisodeDataset
    from biovln_ms.perception.frame_dataset import build_frames_dataset, check_request, parse_resolution
    from biovln_ms.perception.frames import split_sources
    from biovln_ms.splits import dataset_root, held_out_seeds

    size = parse_resolution(frame_size)
    check_request(frames, *size, workers, seed)
    target = given_path(out)
    data = dataset_root(given_path(root) if root is not None else None)
    sources = split_sources(EpisodeDataset(data, verify=False), split, held_out_seeds())
    manifest = build_frames_dataset(
        target,
        sources,
        frames,
        seed,
        size,
        workers,
        progress=sys.stderr.isatty(),
        source_name=f"{data.name}:{split}",
    )
    for part, row in manifest["parts"].items():
        seen = sum(1 for n in row["instances"].values() if n)
        typer.echo(
            f"{part}: {row['frames']} frames, {sum(row['instances'].values())} instances, "
            f"{seen}/{len(row['instances'])} categories, {len(row['scenes'])} scenes"
        )
    typer.echo(f"wrote {target}")
