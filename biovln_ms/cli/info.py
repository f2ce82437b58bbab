"""`biovln-ms doctor` and `biovln-ms catalog`: the install and the instrument catalog."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Optional

import typer
from rich.console import Console

from biovln_ms.cli.common import app


@app.command()
def doctor() -> None:
    """Check the install: versions, Vulkan, assets.

    Versions, the Vulkan device SAPIEN renders with (one frame) and the shipped assets."""
    from biovln_ms.doctor import run_doctor

    raise typer.Exit(run_doctor(typer.echo))


@app.command()
def catalog(
    as_json: bool = typer.Option(False, "--json", help="Print the catalog as a JSON list."),
    path: Optional[Path] = typer.Option(None, help="Another catalog file to validate and print."),
) -> None:
    """Print the instrument catalog.

    The paper's Table 2 plus the goal categories of Tables 6 and 8."""
    from rich.table import Table

    from biovln_ms.catalog import load_catalog

    cat = load_catalog(path)
    if as_json:
        typer.echo(json.dumps(cat.to_json_list(), indent=2))
        return
    table = Table(title=f"Instrument catalog ({cat.source})")
    for col in ("name", "dimensions (m)", "placement", "face", "d_half", "delta", "r", "goal"):
        table.add_column(col)
    for a in cat.assets():
        table.add_row(
            a.name,
            " x ".join(f"{d:.2f}" for d in a.dimensions),
            a.placement,
            a.face or "-",
            f"{a.d_half:.3f}" if a.d_half else "-",
            f"{a.approach_distance}" if a.approach_distance else "-",
            f"{a.success_radius}" if a.success_radius else "-",
            "yes" if a.goal_category else "no",
        )
    Console().print(table)
