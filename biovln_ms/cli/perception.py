"""`biovln-ms perception`: the object detector's labelled frames, its training and its evaluation."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Optional

import typer

from biovln_ms.cli.common import app, given_path
from biovln_ms.measured import source_commit

perception_app = typer.Typer(
    help="The instrument detector.\n\nLabelled frames rendered from the simulator (dataset), its training "
    "(train) and its evaluation on held-out scenes and looks (evaluate).",
    no_args_is_help=True,
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
    from biovln_ms.perception.frames import FRAMES_PER_GROUP, split_sources
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
    for part in (p for p, row in manifest["parts"].items() if not row["frames"]):
        typer.echo(
            f"warning: {part} has no frames: each group of {FRAMES_PER_GROUP} frames draws its part from the "
            "seed; render more (--frames)",
            err=True,
        )
    typer.echo(f"wrote {target}")


@perception_app.command("train")
def perception_train(
    out: Path = typer.Option(
        ..., "-o", "--out", help="Folder for detector.safetensors, train.json, train.png."
    ),
    frames: Path = typer.Option(..., "--frame-data", help="Frame dataset (biovln-ms perception dataset)."),
    seed: int = typer.Option(0, "--seed", help="Seed of the weights' start, data order and augmentation."),
    epochs: Optional[int] = typer.Option(
        None, "--epochs", help="Passes over the training frames (default: the shipped recipe's)."
    ),
    batch: Optional[int] = typer.Option(
        None, "--batch", help="Frames per step (default: the shipped recipe's)."
    ),
    threads: int = typer.Option(2, "--threads", help="CPU threads of torch."),
    input_size: Optional[str] = typer.Option(
        None, "--input-size", help="WIDTHxHEIGHT the net sees (4:3; default: the shipped weights' 160x120)."
    ),
    max_minutes: Optional[float] = typer.Option(
        None, "--max-minutes", help="Stop after this many minutes (the result then depends on the machine)."
    ),
    install: bool = typer.Option(
        False, "--install", help="Also put the weights into the package and its assets manifest."
    ),
) -> None:
    """Train the goal-category detector.

    On a frame dataset's train part: a segmentation net (EfficientNet-Lite0 encoder, small decoder) over
    background and the catalog's goal categories; a tenth of the training groups validates each epoch.
    The held-out parts are not read."""
    from biovln_ms.errors import shown
    from biovln_ms.limits import parse_size
    from biovln_ms.perception.segmenter import INPUT_SIZE, PerceptionError
    from biovln_ms.perception.train_detector import install_weights, train_detector

    size = INPUT_SIZE if input_size is None else parse_size(input_size)
    if size is None:
        raise PerceptionError(
            f"input size {shown(input_size)} is not WIDTHxHEIGHT", field="input_size", fix="e.g. 224x168"
        )
    target = given_path(out)
    data = train_detector(
        given_path(frames),
        target,
        seed=seed,
        threads=threads,
        max_minutes=max_minutes,
        progress=sys.stderr.isatty(),
        commit=source_commit(),
        input_size=size,
        **{k: v for k, v in (("epochs", epochs), ("batch", batch)) if v is not None},
    )
    last = data["history"][-1]
    typer.echo(
        f"{data['epochs_run']} epochs in {data['seconds'] / 60:.1f} min "
        f"({data['whole_seconds'] / 60:.1f} min with reading the frames), loss {last['loss']:.3f}, "
        f"validation recall {last.get('mean_recall')}, precision {last.get('mean_precision')}"
        + (f" ({data['stopped']})" if data["stopped"] else "")
    )
    if install:
        typer.echo(f"installed {install_weights(target / 'detector.safetensors')}")
    typer.echo(f"wrote {target}")


@perception_app.command("evaluate")
def perception_evaluate(
    frames: Path = typer.Option(..., "--frame-data", help="Frame dataset whose held-out parts are measured."),
    weights: Optional[Path] = typer.Option(
        None, "--weights", help="Weights file (default: the shipped one)."
    ),
    lighting: Optional[str] = typer.Option(
        None, "--lighting", help="Only frames of this lighting: fast|quality."
    ),
    noise: Optional[str] = typer.Option(None, "--noise", help="Only frames of this noise: ideal|realistic."),
    as_json: bool = typer.Option(False, "--json", help="Print the results as JSON."),
    out: Optional[Path] = typer.Option(None, "-o", "--out", help="Also write the results JSON here."),
    table: Optional[Path] = typer.Option(None, "--table", help="Also write the docs' measured table here."),
    threads: int = typer.Option(2, "--threads", help="CPU threads of torch."),
) -> None:
    """Measure the detector on held-out frames.

    Per category: precision, recall and mask IoU on held-out scenes and held-out looks. Detections are
    matched to annotated instances at mask IoU >= 0.5; Wilson 95 % intervals; n is the annotated
    instances."""
    import json
    import shlex

    from biovln_ms.io_utils import atomic_write_text
    from biovln_ms.perception.evaluate_detector import HELD_OUT, evaluate_detector, write_table

    result = evaluate_detector(
        given_path(frames),
        given_path(weights) if weights is not None else None,
        lighting=lighting,
        noise=noise,
        threads=threads,
    )
    text = json.dumps(result, indent=1) + "\n"
    if out is not None:
        atomic_write_text(given_path(out), text)
    if table is not None:
        write_table(given_path(table), result, "biovln-ms " + shlex.join(sys.argv[1:]))
    if as_json:
        typer.echo(text, nl=False)
        return
    for cond, parts in result["results"].items():
        for part in HELD_OUT:
            s, b = parts[part], result["results_box"][cond][part]
            typer.echo(
                f"{cond:18s} {part:12s} {s['frames']:4d} frames  mean precision {s['mean_precision']}  "
                f"mean recall {s['mean_recall']}  pixel IoU {s['mean_pixel_iou']}  "
                f"(by box: precision {b['mean_precision']}, recall {b['mean_recall']})"
            )
    ms = result["detect_ms_640x480"]
    if ms:
        typer.echo(f"detection at 640x480: median {ms['median']} ms, p90 {ms['p90']} ms")
