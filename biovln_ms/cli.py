"""The `biovln-ms` command line."""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Optional

import typer
from rich.console import Console

from biovln_ms.errors import BioVLNError

app = typer.Typer(help="BioVLN-MS: operational-face navigation to laboratory instruments (SAPIEN / ManiSkill3).",
                  no_args_is_help=True, pretty_exceptions_enable=False)
assets_app = typer.Typer(help="Generate, verify and preview the procedural instrument assets.", no_args_is_help=True)
app.add_typer(assets_app, name="assets")
scene_app = typer.Typer(help="Generate, validate, map, render and export lab scenes.", no_args_is_help=True)
app.add_typer(scene_app, name="scene")
dataset_app = typer.Typer(help="Build and inspect the episode datasets (paper Tables 3, 4, 12, 13).", no_args_is_help=True)
app.add_typer(dataset_app, name="dataset")
console = Console(stderr=True)


@app.command()
def doctor() -> None:
    """Check versions, the Vulkan device SAPIEN renders with (one frame) and the shipped assets."""
    from biovln_ms.doctor import run_doctor

    raise typer.Exit(run_doctor(typer.echo))


@app.command()
def catalog(as_json: bool = typer.Option(False, "--json", help="Print the catalog as a JSON list."),
            path: Optional[Path] = typer.Option(None, help="Another catalog file to validate and print.")) -> None:
    """Print the instrument catalog (paper Table 2 plus the goal categories of Tables 6 and 8)."""
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
        table.add_row(a.name, " x ".join(f"{d:.2f}" for d in a.dimensions), a.placement, a.face or "-",
                      f"{a.d_half:.3f}" if a.d_half else "-", f"{a.approach_distance}" if a.approach_distance else "-",
                      f"{a.success_radius}" if a.success_radius else "-", "yes" if a.goal_category else "no")
    Console().print(table)


@assets_app.command("generate")
def assets_generate(out: Optional[Path] = typer.Option(None, "-o", "--out", help="Output folder (default: the package's assets/)."),
                    only: Optional[list[str]] = typer.Option(None, "--only", help="Regenerate just these assets.")) -> None:
    """Regenerate the GLB assets and coacd collision caches (bit-identical for the same catalog)."""
    from biovln_ms.assetgen.generate import generate_assets
    from biovln_ms.catalog import load_catalog
    from biovln_ms.paths import ASSET_DIR

    cat = load_catalog()
    for name in only or []:
        if name not in cat and name not in {p.name for p in cat.room_shell}:
            cat.get(name)  # raises with the list of known names
    manifest = generate_assets(out or ASSET_DIR, cat, names=list(only) if only else None)
    typer.echo(f"wrote {len(manifest['files'])} GLBs and {len(manifest['collision'])} collision caches to {out or ASSET_DIR}")


@assets_app.command("verify")
def assets_verify(path: Optional[Path] = typer.Option(None, help="Asset folder (default: the package's).")) -> None:
    """Check every shipped asset against the manifest (missing, corrupt or stale files)."""
    from biovln_ms.assetgen.generate import verify_assets
    from biovln_ms.paths import ASSET_DIR

    problems = verify_assets(path or ASSET_DIR)
    for p in problems:
        typer.echo(p)
    if problems:
        raise typer.Exit(1)
    typer.echo("assets OK")


@assets_app.command("preview")
def assets_preview(out: Path = typer.Option(Path("asset_sheet.png"), "-o", "--out", help="PNG to write."),
                   tile: int = typer.Option(320, help="Tile size in pixels.")) -> None:
    """Render every asset with SAPIEN (front and back, operational face marked) into one contact sheet."""
    from biovln_ms.render.asset_preview import contact_sheet

    renders = contact_sheet(out, tile=tile)
    for r in renders:
        typer.echo(f"{r.name:<18} face {r.face or '-':<3} colours front {r.front_colors:>5}  back {r.back_colors:>5}")
    typer.echo(f"wrote {out}")


@app.command()
def demo(out: Path = typer.Option(Path("outputs/demo"), "-o", "--out", help="Folder for the demo's files.")) -> None:
    """Run the demo: asset sheet, catalog, scene lab_s150_v0 (spec, view, episode map), an oracle episode MP4 and metrics."""
    from biovln_ms.demo import run_demo

    run_demo(out, typer.echo)


@scene_app.command("templates")
def scene_templates() -> None:
    """List the registered layout templates."""
    from biovln_ms.scene.templates import get_template, template_names

    for name in template_names():
        t = get_template(name)
        typer.echo(f"{name:<12} {len(t.slots)} slots, {t.active_slots[0]}-{t.active_slots[1]} active: {t.description}")


@scene_app.command("generate")
def scene_generate(template: str = typer.Option("single_room", "--template", "-t", help="Template name (see `scene templates`)."),
                   seed: int = typer.Option(..., "--seed", "-s", help="Scene seed."),
                   out: Optional[Path] = typer.Option(None, "-o", "--out", help="Spec JSON to write (default: NAME.json)."),
                   require: Optional[list[str]] = typer.Option(None, "--require", help="Categories the scene must hold."),
                   render: Optional[Path] = typer.Option(None, "--render", help="Also write a SAPIEN view from above at an angle."),
                   map_png: Optional[Path] = typer.Option(None, "--map", help="Also write the top-down map.")) -> None:
    """Generate the scene of a seed deterministically and write its spec JSON."""
    from biovln_ms.scene.generator import generate_scene
    from biovln_ms.scene.spec import save_spec

    spec = generate_scene(template, seed, required_categories=tuple(require or ()))
    path = save_spec(spec, out or Path(f"{spec.name}.json"))
    typer.echo(f"wrote {path}: {len(spec.instruments)} instruments ({', '.join(o.id for o in spec.instruments)})")
    if map_png:
        from biovln_ms.scene.topdown import save_map

        typer.echo(f"wrote {save_map(spec, map_png)}")
    if render:
        from biovln_ms.render.scene_view import render_overview

        typer.echo(f"wrote {render_overview(spec, render)}")


@scene_app.command("validate")
def scene_validate(spec_path: Path = typer.Argument(..., help="Scene spec JSON.")) -> None:
    """Check a spec against the schema, the catalog and every layout rule."""
    from biovln_ms.scene.spec import load_spec

    spec = load_spec(spec_path)
    typer.echo(f"{spec_path}: valid ({spec.name}, {len(spec.instruments)} instruments, {len(spec.furniture)} furniture)")


@scene_app.command("map")
def scene_map(spec_path: Path = typer.Argument(..., help="Scene spec JSON."),
              out: Path = typer.Option(Path("map.png"), "-o", "--out", help="PNG to write."),
              dataset: Optional[Path] = typer.Option(None, help="Dataset folder, to overlay one of its episodes."),
              split: str = typer.Option("ms_dev", help="Split of the episode (with --dataset)."),
              episode: Optional[str] = typer.Option(None, help="episode_id to overlay (with --dataset)."),
              islands: bool = typer.Option(False, help="Colour the navigable islands.")) -> None:
    """Draw the top-down map: walls, furniture, Zones 1/2/3, faces, goals, success radii, navigable area;
    optionally islands and one episode's start, goal, view points and shortest path."""
    from biovln_ms.geometry.navigation import scene_navigation
    from biovln_ms.scene.spec import load_spec
    from biovln_ms.scene.topdown import save_map

    spec = load_spec(spec_path)
    ep, radius = None, spec.robot_radius
    if dataset is not None and episode is not None:
        ep, radius = _find_episode(dataset, split, episode, spec.name)
    nav = scene_navigation(spec, radius) if (islands or ep is not None) else None
    typer.echo(f"wrote {save_map(spec, out, episode=ep, nav=nav)}")


def _find_episode(root: Path, split: str, episode: str, scene: Optional[str]) -> tuple[dict, float]:
    from biovln_ms.episodes.dataset import DatasetError, EpisodeDataset

    ds = EpisodeDataset(root)
    ep = next((e for e in ds.episodes(split) if e["episode_id"] == episode and (scene is None or e["scene_id"] == scene)), None)
    if ep is None:
        raise DatasetError(f"no episode '{episode}' in split '{split}'" + (f" for scene '{scene}'" if scene else ""),
                           field="episode", fix="list them with `biovln-ms dataset stats`")
    return ep, ds.agent_radius


@scene_app.command("export")
def scene_export(spec_path: Path = typer.Argument(..., help="Scene spec JSON."),
                 out: Path = typer.Option(Path("lab.glb"), "-o", "--out", help="GLB to write.")) -> None:
    """Write the assembled scene as one GLB: a node per object named by id, category in extras and COLOR_0."""
    from biovln_ms.scene.export_glb import export_scene_glb
    from biovln_ms.scene.spec import load_spec

    spec = load_spec(spec_path)
    typer.echo(f"wrote {export_scene_glb(spec, out)} ({len(spec.objects())} objects)")


@dataset_app.command("build")
def dataset_build(out: Path = typer.Option(Path("data/biovln"), "-o", "--out", help="Dataset folder to (re)write.")) -> None:
    """Build every scene and episode of the paper's datasets, deterministically and atomically."""
    from biovln_ms.episodes.benchmark import paper_splits
    from biovln_ms.episodes.dataset import write_dataset

    m = write_dataset(out, paper_splits())
    for name, s in m["splits"].items():
        note = f"  (missing: {s['missing']})" if s.get("missing") else ""
        typer.echo(f"{name:<12} {len(s['scenes']):>3} scenes {s['episodes']:>5} episodes{note}")
    typer.echo(f"wrote {out}")


@dataset_app.command("stats")
def dataset_stats(root: Path = typer.Argument(..., help="Dataset folder.")) -> None:
    """Scenes, episodes, categories and difficulty mix per split (paper's MS DEV mix beside ours)."""
    from rich.table import Table

    from biovln_ms.episodes.benchmark import PAPER_MS_DEV_DIFFICULTY
    from biovln_ms.episodes.dataset import EpisodeDataset

    ds = EpisodeDataset(root)
    table = Table(title=f"{root} (agent radius {ds.agent_radius} m)")
    for col in ("split", "scenes", "episodes", "categories", "easy %", "medium %", "hard %", "start fallback", "paper"):
        table.add_column(col)
    for name in ds.split_names():
        info = ds.manifest["splits"][name]
        if info.get("missing") and not info["files"]:
            table.add_row(name, "-", "-", "-", "-", "-", "-", "-", f"MISSING: {info['missing']}")
            continue
        st = ds.stats(name)
        d = st["difficulty"]
        paper = ("paper " + " / ".join(f"{v}" for v in PAPER_MS_DEV_DIFFICULTY.values())) if name == "ms_dev" else ""
        table.add_row(name, str(st["scenes"]), str(st["episodes"]), str(len(st["categories"])), f"{d['easy']}",
                      f"{d['medium']}", f"{d['hard']}", str(st["start_fallback"]), paper)
    Console(width=160).print(table)


@dataset_app.command("show")
def dataset_show(root: Path = typer.Argument(..., help="Dataset folder."),
                 split: str = typer.Option("ms_dev", help="Split name."),
                 episode: str = typer.Option("0", help="episode_id (the first scene holding it)."),
                 scene: Optional[str] = typer.Option(None, help="scene_id, when ids repeat across scenes."),
                 out: Path = typer.Option(Path("episode.png"), "-o", "--out", help="PNG to write.")) -> None:
    """Map of one episode: navigable islands, start and heading, goal, view points, shortest path."""
    from biovln_ms.episodes.dataset import EpisodeDataset
    from biovln_ms.geometry.navigation import scene_navigation
    from biovln_ms.scene.topdown import save_map

    ep, radius = _find_episode(root, split, episode, scene)
    spec = EpisodeDataset(root, verify=False).spec(ep["scene_id"])
    typer.echo(f"wrote {save_map(spec, out, episode=ep, nav=scene_navigation(spec, radius))}")


@app.command()
def record(out: Path = typer.Option(Path("episode.mp4"), "-o", "--out", help="MP4 to write."),
           split: str = typer.Option("ms_val", help="Split of the default (or --dataset) dataset."),
           episode: int = typer.Option(0, help="Episode index within the split."),
           policy: str = typer.Option("oracle", help="Policy to run."),
           dataset: Optional[Path] = typer.Option(None, help="Dataset folder (default: built on first use)."),
           env_id: str = typer.Option("BioVLN-OpFace-v0", "--env", help="Env id (a registered variant)."),
           fps: int = typer.Option(5, help="Frames per second.")) -> None:
    """Record one episode: the egocentric view beside a top-down map with trajectory, zones and goal."""
    from biovln_ms.record import record_episode

    m = record_episode(out, split, episode, policy, str(dataset) if dataset else None, env_id, fps=fps)
    typer.echo(f"wrote {out}: success={m['success']} steps={m['steps']} spl={m['spl']:.3f} "
               f"mcr={m['mcr']:.3f} vrt={m['vrt']:.3f}")


@app.command("eval")
def eval_cmd(method: str = typer.Option(..., "--method", "-m", help="Baseline (random, oracle, zone3_oracle, ...)."),
             split: str = typer.Option("ms_dev", "--split", "-s", help="Dataset split."),
             out: Path = typer.Option(Path("results"), "--out", "-o", help="Results folder."),
             dataset: Optional[Path] = typer.Option(None, help="Dataset folder (default: built on first use)."),
             env_id: str = typer.Option("BioVLN-OpFace-v0", "--env", help="Env variant, e.g. BioVLN-Centroid-v0."),
             workers: Optional[int] = typer.Option(None, help="Worker processes (default: one per core)."),
             max_episodes: Optional[int] = typer.Option(None, help="Only the first N episodes."),
             ray_address: Optional[str] = typer.Option(None, help="Run on Ray: 'local' (a local instance), 'auto' or "
                                                                    "'ray://host:port' (a cluster); --workers actors."),
             record: Optional[Path] = typer.Option(None, "--record", help="Record trajectories (TrajectoryRecorder) here."),
             record_mode: str = typer.Option("full", help="full (RGB PNGs + depth) or trace (positions/actions only).")) -> None:
    """Evaluate a method on a split: per-episode JSONL (resumable) and summary.json."""
    from biovln_ms.eval.harness import EvalConfig, evaluate

    cfg = EvalConfig(method, split, str(out), str(dataset) if dataset else None, env_id, workers, max_episodes=max_episodes,
                     ray_address=ray_address, record_dir=str(record) if record else None, record_mode=record_mode)
    o = evaluate(cfg, echo=typer.echo)["overall"]
    typer.echo(f"{cfg.run_name} on {split}: {o['episodes']} episodes, SR {o['sr']:.1f}%, SPL {o['spl']:.3f}, "
               f"DTG {o['dtg']:.2f} m, MCR {o['mcr']:.3f} m, VRT {o['vrt']:.1f}% -> {cfg.run_dir}")


@app.command()
def report(results: Path = typer.Argument(Path("results"), help="Results folder of `biovln-ms eval`."),
           out: Path = typer.Option(Path("report"), "-o", "--out", help="Report folder."),
           dataset: Optional[Path] = typer.Option(None, help="Dataset the results were made on (default dataset if omitted)."),
           videos: int = typer.Option(1, help="How many episode MP4s to record."),
           hard: int = typer.Option(2, help="How many hard-episode figures (re-runs frontier).")) -> None:
    """Write the report: the paper's tables with its numbers beside ours, McNemar tests, plots, renders, MP4s."""
    from biovln_ms.eval.report import write_report

    write_report(results, out, str(dataset) if dataset else None, videos, hard, typer.echo)


def main() -> None:
    """Entry point: user-facing errors print as one clear line, not a traceback."""
    try:
        app()
    except BioVLNError as e:
        console.print(f"[bold red]error:[/] {e}", highlight=False, soft_wrap=True)
        sys.exit(2)


if __name__ == "__main__":
    main()
