"""The commands that run methods: `biovln-ms demo`, `record`, `eval`, `benchmark` and `report`."""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer

from biovln_ms.cli.common import (
    _LEARNED,
    _RECORDABLE,
    _check_lighting,
    _episode_index,
    _lighting_option,
    _methods_help,
    app,
    given_path,
)
from biovln_ms.errors import BioVLNError
from biovln_ms.eval.methods import report_methods
from biovln_ms.limits import MAX_WORKERS
from biovln_ms.variants import BENCHMARK_ENV


@app.command()
def demo(
    out: Path = typer.Option(Path("outputs/demo"), "-o", "--out", help="Folder for the demo's files."),
    lighting: str = _lighting_option("quality"),
) -> None:
    """Run the end-to-end demo.

    Asset sheet, catalog, scene lab_s150_v0 (spec, view, episode map), an oracle episode MP4 and metrics."""
    from biovln_ms.demo import run_demo

    _check_lighting(lighting)
    run_demo(out, typer.echo, lighting=lighting)


@app.command()
def record(
    out: Path = typer.Option(Path("episode.mp4"), "-o", "--out", help="MP4 to write."),
    split: str = typer.Option("ms_val", help="Split of the default (or --dataset) dataset."),
    episode: Optional[str] = typer.Option(None, help="episode_id (default: the first episode)."),
    scene: Optional[str] = typer.Option(None, help="scene_id, when ids repeat across scenes."),
    index: Optional[int] = typer.Option(
        None, help="Position in the split (0: the first), instead of --episode/--scene."
    ),
    policy: str = typer.Option("oracle", help=f"Policy to run: {_RECORDABLE}."),
    dataset: Optional[Path] = typer.Option(None, help="Dataset folder (default: built on first use)."),
    env_id: str = typer.Option(BENCHMARK_ENV, "--env", help="Env id (a registered variant)."),
    fps: int = typer.Option(5, help="Frames per second."),
    lighting: str = _lighting_option(),
) -> None:
    """Record one episode as an MP4.

    The egocentric view beside a top-down map with trajectory, zones and goal."""
    from biovln_ms.splits import dataset_root
    from biovln_ms.episode_video import record_episode

    _check_lighting(lighting)
    root = dataset_root(dataset)
    k = _record_index(root, split, episode, scene, index)
    m = record_episode(out, split, k, policy, str(root), env_id, fps=fps, lighting=lighting)
    typer.echo(
        f"wrote {out}: success={m['success']} steps={m['steps']} spl={m['spl']:.3f} "
        f"mcr={m['mcr']:.3f} vrt={m['vrt']:.3f}"
    )


def _record_index(
    root: Path, split: str, episode: Optional[str], scene: Optional[str], index: Optional[int]
) -> int:
    """The position in the split ``record`` runs: ``--index``, else that of ``--episode``/``--scene``."""
    from biovln_ms.episodes.dataset import DatasetError, EpisodeDataset

    episodes = list(EpisodeDataset(root, verify=False).episodes(split))
    if index is None:
        alternative = "; --index K picks the split's K-th episode" if episode and episode.isdigit() else ""
        return _episode_index(episodes, split, episode, scene, alternative)
    if episode is not None or scene is not None:
        raise BioVLNError(
            "--index and --episode/--scene both given", field="--index", fix="choose the episode one way"
        )
    if not 0 <= index < len(episodes):
        raise DatasetError(
            f"--index {index} is out of range for split '{split}'",
            field="--index",
            fix=f"use 0 <= K < {len(episodes)}",
        )
    return index


@app.command(
    "eval",
    help="Evaluate a method on a split.\n\nPer-episode JSONL (resumable) and summary.json.\n\n"
    "Exit status 1 when an episode failed to run (it counts as a failure; running again retries it), "
    "2 on a usage error or when another eval is writing the same results folder (eval.lock).\n\n"
    "Methods (--method):\n\n" + _methods_help(),
)
def eval_cmd(
    method: str = typer.Option(
        ..., "--method", "-m", help=f"Method: {', '.join(report_methods())}.", autocompletion=report_methods
    ),
    split: str = typer.Option("ms_dev", "--split", "-s", help="Dataset split."),
    out: Path = typer.Option(Path("results"), "--out", "-o", help="Results folder.", parser=given_path),
    dataset: Optional[Path] = typer.Option(
        None, help="Dataset folder (default: built on first use).", parser=given_path
    ),
    env_id: Optional[str] = typer.Option(
        None,
        "--env",
        help="Env variant, e.g. BioVLN-Centroid-v0 (default: BioVLN-OpFace-v0, or the method's own above).",
    ),
    workers: Optional[int] = typer.Option(
        None, min=1, max=MAX_WORKERS, help="Worker processes (default: one per core)."
    ),
    max_episodes: Optional[int] = typer.Option(None, min=1, help="Only the first N episodes (default: all)."),
    ray_address: Optional[str] = typer.Option(
        None,
        help="Run on Ray: 'local' (a local instance), 'auto' or "
        "'ray://host:port' (a cluster); --workers actors.",
    ),
    record: Optional[Path] = typer.Option(
        None, "--record", help="Record trajectories (TrajectoryRecorder) here.", parser=given_path
    ),
    record_mode: str = typer.Option(
        "full", help="full (RGB PNGs + depth) or trace (positions/actions only)."
    ),
    checkpoint: Optional[Path] = typer.Option(
        None,
        help=f"Checkpoint of a learned method ({_LEARNED}): bc.pt for bc, a Stable-Baselines3 .zip for RL.",
        parser=given_path,
    ),
    detector: Optional[str] = typer.Option(
        None,
        help="vlfm: 'trained' (default, the shipped weights), 'trained:FILE' or 'owlvit:/local/dir'; "
        "'gt' runs the method's GT-detector ablation (simulator segmentation): vlfm_gt, protocol_vlfm_gt.",
    ),
    scorer: Optional[str] = typer.Option(
        None, help="vlfm: 'default' (packaged EfficientNet-Lite0 + MiniLM) or 'clip:/local/dir'."
    ),
    parser: Optional[str] = typer.Option(
        None, help="protocol_language: 'rule' (default, offline) or 'llm' (an LLM reads the instruction)."
    ),
    name: Optional[str] = typer.Option(
        None, help="Results folder name: letters, digits, _ - . + @ (default: the method)."
    ),
    noise: str = typer.Option(
        "ideal", help="Noise preset: ideal (the paper) or realistic; the run is named METHOD+PRESET."
    ),
    robot: str = typer.Option(
        "biovln_base",
        "--robot",
        help="Robot: biovln_base or fetch (its own default dataset; the run is named METHOD-fetch).",
    ),
    export_handoff: Optional[Path] = typer.Option(
        None,
        "--export-handoff",
        help="Write each successful episode's hand-off JSON here (final base pose, joints, scene).",
        parser=given_path,
    ),
    fresh_scene: bool = typer.Option(
        False,
        "--fresh-scene",
        help="Rebuild the scene at every episode (0.3-0.75 s each): outcomes that do not depend on the "
        "episodes a worker ran before (contacts; see the noise presets guide).",
    ),
) -> None:
    from biovln_ms.eval.harness import EvalConfig, evaluate
    from biovln_ms.eval.methods import GT_ABLATION
    from biovln_ms.eval.tables import headline
    from biovln_ms.perception.detector_specs import GT_SPEC

    if detector == GT_SPEC and method in GT_ABLATION:  # the ablation is its own method (another observation)
        method, detector = GT_ABLATION[method], None
        typer.echo(f"--detector gt: running the GT-detector ablation, method {method}")
    given = {"checkpoint": str(checkpoint) if checkpoint else None, "detector": detector, "scorer": scorer}
    given["parser"] = parser
    kwargs = {k: v for k, v in given.items() if v is not None}
    cfg = EvalConfig(
        method,
        split,
        str(out),
        str(dataset) if dataset else None,
        env_id,
        workers,
        max_episodes=max_episodes,
        ray_address=ray_address,
        record_dir=str(record) if record else None,
        record_mode=record_mode,
        method_kwargs=kwargs,
        name=name,
        noise=noise,
        robot=robot,
        handoff_dir=str(export_handoff) if export_handoff else None,
        fresh_scene=fresh_scene,
    )
    summary = evaluate(cfg, echo=typer.echo)
    o = summary["overall"]
    typer.echo(
        f"{cfg.run_name} on {split}: {o['episodes']} episodes, {headline(summary)}, errors: {o['errors']} "
        f"-> {cfg.run_dir}"
    )
    if o.get("reach_successes") is not None:  # Fetch: the reach check at STOP
        typer.echo(
            f"reach SR {o['reach_sr']:.1f}% (the gripper reaches the interaction point); reachable: "
            f"{o['reachable_of_successes']:.1f}% of the successes"
        )
    if o["errors"]:  # counted as failures; the exit status says the numbers include them
        typer.echo(
            f"error: {o['errors']} of {o['episodes']} episodes failed to run (counted as failures, "
            f"left out of DTG/MCR/VRT); their reasons are the \"error\" fields in "
            f"{cfg.run_dir / 'episodes.jsonl'} (fix: run the same command again to retry them)",
            err=True,
        )
        raise typer.Exit(1)


@app.command(
    "benchmark",
    help="Run the whole benchmark, then report.\n\n"
    "Every method on every benchmark split under every noise preset, and with people in the lab (the busy "
    "splits; --no-people leaves them out). Resumable (run it again after a "
    "kill); trains PPO and BC once when no --checkpoints are given; suite.json / suite.md in --out keep "
    "each run's status and wall time; --report writes the report.",
)
def benchmark_cmd(
    out: Path = typer.Option(Path("benchmark"), "--out", "-o", help="Suite folder (results/, checkpoints/)."),
    report_dir: Optional[Path] = typer.Option(None, "--report", help="Write the report here at the end."),
    methods: Optional[str] = typer.Option(
        None, "--methods", help="Only these methods, comma-separated (default: all but a2c/sac)."
    ),
    splits: Optional[str] = typer.Option(
        None,
        "--splits",
        help="Only these splits, comma-separated (default: MS VAL/TEST, Two-Room, LSAT, Hard).",
    ),
    noises: Optional[str] = typer.Option(
        None, "--presets", help="Only these noise presets, comma-separated (default: ideal,realistic)."
    ),
    checkpoints: Optional[str] = typer.Option(
        None,
        "--checkpoints",
        help="METHOD=PATH of learned methods, comma-separated (default: the suite trains them).",
    ),
    workers: Optional[int] = typer.Option(
        None, min=1, max=MAX_WORKERS, help="Worker processes (default: one per core)."
    ),
    dataset: Optional[Path] = typer.Option(
        None, help="Dataset folder (default: built on first use).", parser=given_path
    ),
    people: bool = typer.Option(
        True, "--people/--no-people", help="Also run the methods with people in the lab (the busy splits)."
    ),
) -> None:
    from biovln_ms.errors import BioVLNError
    from biovln_ms.eval.suite import PROTOCOL_METHODS, SUITE_METHODS, SUITE_NOISE, SUITE_SPLITS, run_suite

    def names(value: str | None, default: tuple[str, ...]) -> list[str]:
        return [v.strip() for v in value.split(",") if v.strip()] if value else list(default)

    given = {}
    for item in names(checkpoints, ()):
        method, sep, path = item.partition("=")
        if not sep or not path:
            raise BioVLNError(
                f"--checkpoint '{item}' is not METHOD=PATH",
                field="checkpoint",
                fix="e.g. --checkpoints ppo=runs/ppo/model.zip",
            )
        given[method] = path
    run_suite(
        out,
        names(methods, SUITE_METHODS + PROTOCOL_METHODS),
        names(splits, SUITE_SPLITS),
        names(noises, SUITE_NOISE),
        workers,
        str(dataset) if dataset else None,
        given,
        report_dir,
        echo=typer.echo,
        people=people,
    )


@app.command()
def report(
    results: Path = typer.Argument(Path("results"), help="Results folder of `biovln-ms eval`."),
    out: Path = typer.Option(Path("report"), "-o", "--out", help="Report folder."),
    dataset: Optional[Path] = typer.Option(
        None, help="Dataset the results were made on (default dataset if omitted)."
    ),
    videos: int = typer.Option(1, help="How many episode MP4s to record."),
    hard: int = typer.Option(2, help="How many hard-episode figures (re-runs frontier)."),
) -> None:
    """Write the report of eval results.

    The paper's tables with its numbers beside ours, McNemar tests, plots, renders, MP4s."""
    from biovln_ms.eval.report import write_report

    write_report(results, out, str(dataset) if dataset else None, videos, hard, typer.echo)
