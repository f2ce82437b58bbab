"""`biovln-ms export`: a scene's files for the tools robots already run (Nav2), recordings for LeRobot."""

from __future__ import annotations

from pathlib import Path

import typer

from biovln_ms.cli.common import app

export_app = typer.Typer(
    help="Export scenes and recordings to robot tools.\n\n"
    "The tools robots already run: Nav2 maps, keep-out masks, goals; LeRobot datasets of recorded episodes.",
    no_args_is_help=True,
)
app.add_typer(export_app, name="export")


@export_app.command("nav2")
def export_nav2_cmd(
    spec_path: Path = typer.Argument(..., help="Scene spec JSON."),
    out: Path = typer.Option(..., "-o", "--out", help="Folder to write the Nav2 files into."),
    resolution: float = typer.Option(0.05, help="Map resolution in metres per pixel."),
) -> None:
    """Write a scene's Nav2 files.

    map_server map (raw occupancy), keep-out filter mask (Zones 1-2), goal poses (PoseStamped, frame
    map), costmap parameters and a preview PNG."""
    from biovln_ms.bridges.nav2 import export_nav2
    from biovln_ms.scene.loading import load_spec
    from biovln_ms.scene.rules import validate_spec

    spec = validate_spec(load_spec(spec_path), str(spec_path))
    files = export_nav2(spec, out, resolution)
    typer.echo(f"wrote {len(files)} files to {out}: {', '.join(f.name for f in files)}")


@export_app.command("lerobot")
def export_lerobot_cmd(
    recording: Path = typer.Argument(..., help="Recording folder of `eval --record DIR`."),
    out: Path = typer.Option(..., "-o", "--out", help="Dataset folder to create (must not exist)."),
    fps: int = typer.Option(5, help="Frames per second: policy steps per second of the timestamps."),
) -> None:
    """Recorded episodes as a LeRobot dataset.

    A LeRobotDataset v3.0 of what `eval --record` wrote: RGB as H.264 video, depth in metres, pose,
    goal, actions, done and success flags, in the parquet and MP4 files LeRobotDataset(repo_id, root=DIR)
    loads."""
    from biovln_ms.bridges.lerobot import export_lerobot

    info = export_lerobot(recording, out, fps=fps)
    typer.echo(
        f"wrote {out}: LeRobotDataset {info['codebase_version']}, {info['total_episodes']} episodes, "
        f"{info['total_frames']} frames, {info['total_tasks']} tasks"
    )
