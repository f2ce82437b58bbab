"""`biovln-ms lsat` (designer-authored scenes: import, export, the Blender add-on, the target scene) and
`biovln-ms layout` (LLM-assisted layout design)."""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer

from biovln_ms.cli.common import app
from biovln_ms.errors import BioVLNError

lsat_app = typer.Typer(
    help="Designer-authored scenes (LSAT).\n\nImport a GLB with target_* markers; export goals, the LSAT "
    "format or USD.",
    no_args_is_help=True,
)
app.add_typer(lsat_app, name="lsat")
layout_app = typer.Typer(
    help="LLM-assisted layout design.\n\nA description (or a structured request) -> a valid scene spec.",
    no_args_is_help=True,
)
app.add_typer(layout_app, name="layout")


@lsat_app.command("import")
def lsat_import(
    glb: Path = typer.Argument(..., help="Designer GLB (Blender export, +Y up)."),
    out: Path = typer.Option(..., "-o", "--out", help="Scene spec JSON to write."),
    report: Optional[Path] = typer.Option(None, help="Coverage report (Markdown); default beside --out."),
    name: Optional[str] = typer.Option(None, help="Scene name (default: the GLB's file name)."),
    allow_external: bool = typer.Option(
        False, help="Read buffers/images referenced beside the GLB (never outside its folder)."
    ),
    names: Optional[Path] = typer.Option(
        None,
        "--names",
        help="Name map (YAML/JSON): node name or glob -> category, or null; wins over the catalog's names.",
    ),
) -> None:
    """Import a designer-authored GLB (paper P1).

    Goals from target_* markers (strategy 1) or from geometry + Eq. 1 (strategy 2). A failing import lists
    every problem, and its report is written all the same."""
    from biovln_ms.io_utils import atomic_write_text
    from biovln_ms.lsat.importer import import_glb
    from biovln_ms.lsat.name_map import load_name_map

    name_map = load_name_map(names) if names else None
    rpath = report or out.with_suffix(".report.md")  # written even when the import fails
    spec, rep = import_glb(glb, name=name, allow_external=allow_external, names=name_map, report_path=rpath)
    atomic_write_text(out, spec.to_json())
    c = rep.coverage()
    adopted = len(c["instruments_from_markers"])
    typer.echo(
        f"wrote {out}: {c['instruments_found']} instruments, goals from markers {c['goals_strategy1']}, "
        f"from Eq. 1 {c['goals_strategy2']}, missing {len(c['missing'])}, "
        + (f"{adopted} recognised only by their marker (check them), " if adopted else "")
        + f"{len(rep.warnings)} warning(s) -> {rpath}"
    )


@lsat_app.command("export")
def lsat_export(
    spec_path: Path = typer.Argument(..., help="Scene spec JSON (imported or procedural)."),
    goals: Optional[Path] = typer.Option(None, help="BioVLN goal JSON to write."),
    lsat: Optional[Path] = typer.Option(None, help="LSAT intermediate-format JSON to write."),
    usd: Optional[Path] = typer.Option(None, help="USD stage to write (.usda text, .usd/.usdc binary)."),
) -> None:
    """Export goals, LSAT format and/or USD.

    A scene's goals (BioVLN JSON), the LSAT intermediate format and/or a USD stage for Isaac Sim."""
    from biovln_ms.lsat.exporters import goal_json, lsat_json, write_json, write_usd
    from biovln_ms.scene.loading import load_spec
    from biovln_ms.scene.rules import validate_spec

    if not (goals or lsat or usd):
        raise BioVLNError(
            "nothing to export", field="--goals/--lsat/--usd", fix="name at least one output file"
        )
    spec = validate_spec(load_spec(spec_path), str(spec_path))
    for path, write in (
        (goals, lambda p: write_json(goal_json(spec), p)),
        (lsat, lambda p: write_json(lsat_json(spec), p)),
        (usd, lambda p: write_usd(spec, p)),
    ):
        if path:
            typer.echo(f"wrote {write(path)}")


@lsat_app.command("blender-addon")
def lsat_blender_addon(
    out: Path = typer.Option(Path("biovln_lsat.zip"), "-o", "--out", help="Zip to write."),
) -> None:
    """Package the Blender add-on as a zip.

    Install it with Edit > Preferences > Add-ons > Install from Disk."""
    from biovln_ms.io_utils import atomic_write_bytes
    from biovln_ms.lsat.addon_zip import addon_zip_bytes

    typer.echo(
        f"wrote {atomic_write_bytes(out, addon_zip_bytes())} (install it from Blender's add-on preferences)"
    )


@lsat_app.command("build-target")
def lsat_build_target(
    out: Path = typer.Option(None, "-o", "--out", help="GLB to write (default: the shipped one)."),
) -> None:
    """Regenerate the LSAT Target scene GLB.

    The designer's layout; deterministic bytes."""
    from biovln_ms.lsat.designer_scene import target_glb_path, write_target_glb

    typer.echo(f"wrote {write_target_glb(out or target_glb_path())}")


def _write_layout(spec, notes, out: Path, map_png: Optional[Path]) -> None:
    from biovln_ms.io_utils import atomic_write_text

    atomic_write_text(out, spec.to_json())
    for n in notes:
        typer.echo(f"note: {n}")
    if map_png:
        from biovln_ms.scene.topdown import save_map

        save_map(spec, map_png)
    typer.echo(
        f"wrote {out}: {len(spec.instruments)} instruments, {len(spec.furniture)} furniture; "
        "passes every generator rule"
    )


@layout_app.command("solve")
def layout_solve(
    request: Path = typer.Argument(
        ..., help="Layout request (YAML or JSON; schema: biovln_ms/lsat/layout.py)."
    ),
    out: Path = typer.Option(..., "-o", "--out", help="Scene spec JSON to write."),
    map_png: Optional[Path] = typer.Option(None, "--map", help="Also write its top-down map."),
) -> None:
    """Solve a structured layout request offline.

    Our placement solver; no LLM."""
    from biovln_ms.lsat.layout import load_request, solve_layout

    spec, notes = solve_layout(load_request(request))
    _write_layout(spec, notes, out, map_png)


@layout_app.command("suggest")
def layout_suggest(
    description: str = typer.Argument(..., help='e.g. "a cell-culture room with two incubators and a BSC"'),
    out: Path = typer.Option(..., "-o", "--out", help="Scene spec JSON to write."),
    request_out: Optional[Path] = typer.Option(
        None, help="Also keep the LLM's request (JSON) to edit and re-solve."
    ),
    map_png: Optional[Path] = typer.Option(None, "--map", help="Also write its top-down map."),
) -> None:
    """Lay out a description with the LLM.

    Ask the LLM (BIOVLN_LLM_* endpoint) for a layout request, validate it, and solve it."""
    from biovln_ms.io_utils import atomic_write_text
    from biovln_ms.lsat.layout import request_json, solve_layout, suggest_request

    req = suggest_request(description)
    if request_out:
        atomic_write_text(request_out, request_json(req))
    spec, notes = solve_layout(req)
    _write_layout(spec, notes, out, map_png)
