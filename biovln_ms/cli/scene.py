"""`biovln-ms scene`: generate, validate, map and export lab scene specs."""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer
from typer.core import TyperCommand

from biovln_ms.cli.common import _check_lighting, _find_episode, _lighting_option, app

scene_app = typer.Typer(
    help="Generate, validate, map and export scenes.\n\nLab scene specs: generate, validate, map, render "
    "and export them.",
    no_args_is_help=True,
)
app.add_typer(scene_app, name="scene")


@scene_app.command("templates")
def scene_templates() -> None:
    """List the registered layout templates."""
    from biovln_ms.scene.templates import get_template, template_names

    for name in template_names():
        t = get_template(name)
        typer.echo(
            f"{name:<12} {len(t.slots)} slots, {t.active_slots[0]}-{t.active_slots[1]} active: "
            f"{t.description}"
        )


def _split_categories(values: list[str] | None) -> list[str]:
    """``--require`` values split on commas and spaces: ``a,b`` and ``"a b"`` both give ``[a, b]``."""
    return [c for v in values or () for c in v.replace(",", " ").split()]


class _GreedyRequireCommand(TyperCommand):
    """Reads ``--require a b c`` as ``--require a --require b --require c`` (a click option takes one
    value per flag): every word after ``--require`` up to the next option is a category."""

    def parse_args(self, ctx: typer.Context, args: list[str]) -> list[str]:
        out: list[str] = []
        greedy = False
        for i, tok in enumerate(args):
            if tok == "--":
                out += args[i:]
                break
            if tok.startswith("-"):
                greedy = tok == "--require" or tok.startswith("--require=")
            elif greedy and out[-1] != "--require":
                out.append("--require")
            out.append(tok)
        return super().parse_args(ctx, out)


@scene_app.command("generate", cls=_GreedyRequireCommand)
def scene_generate(
    template: str = typer.Option(
        "single_room", "--template", "-t", help="Template name (see `scene templates`)."
    ),
    seed: int = typer.Option(..., "--seed", help="Scene seed."),
    out: Optional[Path] = typer.Option(None, "-o", "--out", help="Spec JSON to write (default: NAME.json)."),
    require: list[str] | None = typer.Option(
        None,
        "--require",
        metavar="CAT...",
        callback=_split_categories,
        help="Categories the scene must hold: --require a b, --require a,b or --require a --require b.",
    ),
    render: Optional[Path] = typer.Option(
        None, "--render", help="Also write a SAPIEN view from above at an angle."
    ),
    map_png: Optional[Path] = typer.Option(None, "--map", help="Also write the top-down map."),
    lighting: str = _lighting_option(),
    dressing: bool = typer.Option(
        False, "--dressing", help="Add lab dressing: shelves, a sink, an eyewash, posters, stools, a trolley."
    ),
) -> None:
    """Generate a scene spec from a seed.

    Deterministic: the same template and seed give the same spec JSON."""
    from biovln_ms.scene.generator import generate_scene
    from biovln_ms.scene.spec import save_spec

    _check_lighting(lighting)
    spec = generate_scene(template, seed, required_categories=tuple(require or ()), dressing=dressing)
    path = save_spec(spec, out or Path(f"{spec.name}.json"))
    dressed = f"; {len(spec.dressing)} pieces of lab dressing" if spec.dressing else ""
    typer.echo(
        f"wrote {path}: {len(spec.instruments)} instruments ({', '.join(o.id for o in spec.instruments)})"
        + dressed
    )
    if map_png:
        from biovln_ms.scene.topdown import save_map

        typer.echo(f"wrote {save_map(spec, map_png)}")
    if render:
        from biovln_ms.render.scene_view import render_overview

        typer.echo(f"wrote {render_overview(spec, render, lighting=lighting)}")


@scene_app.command("validate")
def scene_validate(spec_path: Path = typer.Argument(..., help="Scene spec JSON.")) -> None:
    """Check a spec: schema, catalog, layout rules."""
    from biovln_ms.scene.loading import load_spec
    from biovln_ms.scene.rules import validate_spec

    spec = validate_spec(load_spec(spec_path), str(spec_path))
    typer.echo(
        f"{spec_path}: valid ({spec.name}, {len(spec.instruments)} instruments, "
        f"{len(spec.furniture)} furniture)"
    )


@scene_app.command("map")
def scene_map(
    spec_path: Path = typer.Argument(..., help="Scene spec JSON."),
    out: Path = typer.Option(Path("map.png"), "-o", "--out", help="PNG to write."),
    dataset: Optional[Path] = typer.Option(None, help="Dataset folder, to overlay one of its episodes."),
    split: str = typer.Option("ms_dev", help="Split of the episode (with --dataset)."),
    episode: Optional[str] = typer.Option(None, help="episode_id to overlay (with --dataset)."),
    islands: bool = typer.Option(False, help="Colour the navigable islands."),
) -> None:
    """Draw a scene's top-down map.

    Walls, furniture, Zones 1/2/3, faces, goals, success radii, navigable area; optionally islands and one
    episode's start, goal, view points and shortest path."""
    from biovln_ms.scene.loading import load_spec
    from biovln_ms.scene.rules import scene_navigation, validate_spec
    from biovln_ms.scene.topdown import save_map

    spec = validate_spec(load_spec(spec_path), str(spec_path))
    ep, radius = None, spec.robot_radius
    if dataset is not None and episode is not None:
        ep, radius = _find_episode(dataset, split, episode, spec.name)
    nav = scene_navigation(spec, radius) if (islands or ep is not None) else None
    typer.echo(f"wrote {save_map(spec, out, episode=ep, nav=nav)}")


@scene_app.command("export")
def scene_export(
    spec_path: Path = typer.Argument(..., help="Scene spec JSON."),
    out: Path = typer.Option(Path("lab.glb"), "-o", "--out", help="GLB to write."),
) -> None:
    """Write the assembled scene as one GLB.

    A node per object named by id, category in extras and COLOR_0."""
    from biovln_ms.scene.export_glb import export_scene_glb
    from biovln_ms.scene.loading import load_spec
    from biovln_ms.scene.rules import validate_spec

    spec = validate_spec(load_spec(spec_path), str(spec_path))
    typer.echo(f"wrote {export_scene_glb(spec, out)} ({len(spec.objects())} objects)")
