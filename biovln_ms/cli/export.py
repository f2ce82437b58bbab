"""`biovln-ms export`: a scene's files for the tools robots already run (Nav2)."""

from __future__ import annotations

from pathlib import Path

import typer

from biovln_ms.cli.common import app

export_app = typer.Typer(
    help="Export scenes to robot tools.\n\nThe tools robots already run: Nav2 maps, keep-out masks, goals.",
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
