"""`biovln-ms assets`: generate, verify and preview the procedural instrument assets."""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer

from biovln_ms.cli.common import _check_lighting, _lighting_option, app

assets_app = typer.Typer(
    help="Generate, verify and preview the assets.\n\nThe procedural instrument GLBs and their coacd "
    "collision caches.",
    no_args_is_help=True,
)
app.add_typer(assets_app, name="assets")


@assets_app.command("generate")
def assets_generate(
    out: Optional[Path] = typer.Option(
        None, "-o", "--out", help="Output folder (default: the package's assets/)."
    ),
    only: Optional[list[str]] = typer.Option(None, "--only", help="Regenerate just these assets."),
) -> None:
    """Regenerate the GLB assets and coacd caches.

    Bit-identical for the same catalog."""
    from biovln_ms.assetgen.generate import generate_assets
    from biovln_ms.catalog import load_catalog
    from biovln_ms.paths import ASSET_DIR

    cat = load_catalog()
    for name in only or []:
        if name not in cat and name not in {p.name for p in cat.room_shell}:
            cat.get(name)  # raises with the list of known names
    manifest = generate_assets(out or ASSET_DIR, cat, names=list(only) if only else None)
    typer.echo(
        f"wrote {len(manifest['files'])} GLBs and {len(manifest['collision'])} collision caches "
        f"to {out or ASSET_DIR}"
    )


@assets_app.command("verify")
def assets_verify(
    path: Optional[Path] = typer.Option(None, help="Asset folder (default: the package's)."),
) -> None:
    """Check shipped assets against the manifest.

    Missing, corrupt or stale files (generated from another catalog)."""
    from biovln_ms.assetgen.generate import verify_assets
    from biovln_ms.paths import ASSET_DIR

    problems = verify_assets(path or ASSET_DIR)
    for p in problems:
        typer.echo(p)
    if problems:
        raise typer.Exit(1)
    typer.echo("assets OK")


@assets_app.command("preview")
def assets_preview(
    out: Path = typer.Option(Path("asset_sheet.png"), "-o", "--out", help="PNG to write."),
    tile: int = typer.Option(320, help="Tile size in pixels."),
    lighting: str = _lighting_option("quality"),
) -> None:
    """Render every asset into one contact sheet.

    SAPIEN views, front and back, operational face marked, lit by a lighting preset over a 4 m room."""
    from biovln_ms.render.asset_preview import contact_sheet

    _check_lighting(lighting)
    renders = contact_sheet(out, tile=tile, lighting=lighting)
    for r in renders:
        typer.echo(
            f"{r.name:<18} face {r.face or '-':<3} colours front {r.front_colors:>5}  back {r.back_colors:>5}"
        )
    typer.echo(f"wrote {out}")
