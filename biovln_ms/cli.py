"""The `biovln-ms` command line."""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Optional

import typer
from rich.console import Console
from rich.markup import escape
from typer.core import TyperCommand

from biovln_ms.errors import BioVLNError
from biovln_ms.eval.methods import METHODS, RL_ENV, SB3_CONTROL_MODES, report_methods
from biovln_ms.plugins import load_plugins

app = typer.Typer(
    help="BioVLN-MS: operational-face navigation to laboratory instruments (SAPIEN / ManiSkill3).",
    no_args_is_help=True,
    pretty_exceptions_enable=False,
)
assets_app = typer.Typer(
    help="Generate, verify and preview the assets.\n\nThe procedural instrument GLBs and their coacd "
    "collision caches.",
    no_args_is_help=True,
)
app.add_typer(assets_app, name="assets")
scene_app = typer.Typer(
    help="Generate, validate, map and export scenes.\n\nLab scene specs: generate, validate, map, render "
    "and export them.",
    no_args_is_help=True,
)
app.add_typer(scene_app, name="scene")
dataset_app = typer.Typer(
    help="Build and inspect the episode datasets.\n\nThe paper's Tables 3, 4, 12 and 13.",
    no_args_is_help=True,
)
app.add_typer(dataset_app, name="dataset")
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
train_app = typer.Typer(
    help="Train learned policies (BC and RL).\n\nBehavioural cloning (bc) and RL with Stable-Baselines3 "
    f"({', '.join(SB3_CONTROL_MODES)}).",
    no_args_is_help=True,
)
app.add_typer(train_app, name="train")
export_app = typer.Typer(
    help="Export scenes to robot tools.\n\nThe tools robots already run: Nav2 maps, keep-out masks, goals.",
    no_args_is_help=True,
)
app.add_typer(export_app, name="export")
console = Console(stderr=True)


def _method_line(name: str) -> str:
    """A registered method: name, label, description and what it needs."""
    s = METHODS[name]
    return (
        f"{name:<13} {s.label} — {s.description}"
        + ("; privileged" if s.privileged else "")
        + (f"; runs on {s.env_id}" if s.env_id else "")
    )


def _methods_help() -> str:
    """One line per registered method, in report order."""
    return "\n".join(_method_line(m) for m in report_methods())


_RECORDABLE = ", ".join(m for m in report_methods() if METHODS[m].recordable)  # what `record` can run as is
_LEARNED = ", ".join(m for m in report_methods() if "checkpoint" in METHODS[m].options)


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


def _lighting_option(default: str = "fast"):
    from biovln_ms.render.lighting import LIGHTING

    return typer.Option(
        default,
        "--lighting",
        help=f"Lighting preset: {', '.join(LIGHTING)} (quality: shadowed ceiling lights).",
    )


def _check_lighting(name: str) -> None:
    """A one-line error for an unknown preset before anything is built."""
    from biovln_ms.render.lighting import lighting_preset

    lighting_preset(name)


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

    spec = load_spec(spec_path)
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
    from biovln_ms.scene.rules import scene_navigation
    from biovln_ms.scene.loading import load_spec
    from biovln_ms.scene.topdown import save_map

    spec = load_spec(spec_path)
    ep, radius = None, spec.robot_radius
    if dataset is not None and episode is not None:
        ep, radius = _find_episode(dataset, split, episode, spec.name)
    nav = scene_navigation(spec, radius) if (islands or ep is not None) else None
    typer.echo(f"wrote {save_map(spec, out, episode=ep, nav=nav)}")


def _episode_index(
    episodes: list[dict], split: str, episode: Optional[str], scene: Optional[str], alternative: str = ""
) -> int:
    """Position of ``--episode`` (an episode_id; None: the first) of ``--scene`` (None: the first scene
    holding it) among a split's episodes; a miss names the ids there are (and ``alternative``)."""
    from biovln_ms.episodes.dataset import DatasetError

    here = [i for i, e in enumerate(episodes) if scene in (None, e["scene_id"])]
    k = next((i for i in here if episode in (None, episodes[i]["episode_id"])), None)
    if k is None:
        ids = sorted({episodes[i]["episode_id"] for i in here}, key=lambda x: (len(x), x))
        there = f"ids there run '{ids[0]}'..'{ids[-1]}'" if ids else "no episode there"
        raise DatasetError(
            ("no episode" if episode is None else f"no episode '{episode}'")
            + f" in split '{split}'"
            + (f" for scene '{scene}'" if scene else ""),
            field="--episode",
            fix=f"--episode takes an episode_id: {there}{alternative}",
        )
    return k


def _find_episode(root: Path, split: str, episode: Optional[str], scene: Optional[str]) -> tuple[dict, float]:
    from biovln_ms.episodes.dataset import EpisodeDataset

    ds = EpisodeDataset(root, robot=None)  # any robot's: the map is drawn for the dataset's radius
    episodes = list(ds.episodes(split))
    return episodes[_episode_index(episodes, split, episode, scene)], ds.agent_radius


@scene_app.command("export")
def scene_export(
    spec_path: Path = typer.Argument(..., help="Scene spec JSON."),
    out: Path = typer.Option(Path("lab.glb"), "-o", "--out", help="GLB to write."),
) -> None:
    """Write the assembled scene as one GLB.

    A node per object named by id, category in extras and COLOR_0."""
    from biovln_ms.scene.export_glb import export_scene_glb
    from biovln_ms.scene.loading import load_spec

    spec = load_spec(spec_path)
    typer.echo(f"wrote {export_scene_glb(spec, out)} ({len(spec.objects())} objects)")


@dataset_app.command("build")
def dataset_build(
    out: Path = typer.Option(Path("data/biovln"), "-o", "--out", help="Dataset folder to (re)write."),
    robot: str = typer.Option(
        "biovln_base", "--robot", help="Robot the scenes and episodes are made for: biovln_base, fetch."
    ),
) -> None:
    """Build the paper's datasets.

    Every scene and episode, deterministically and atomically, for one robot (its footprint radius)."""
    from biovln_ms.benchmark import paper_splits
    from biovln_ms.episodes.dataset import write_dataset
    from biovln_ms.robots import robot_spec

    robot_spec(robot, "--robot")
    m = write_dataset(out, paper_splits(robot), robot=robot)
    for name, s in m["splits"].items():
        note = f"  (missing: {s['missing']})" if s.get("missing") else ""
        typer.echo(f"{name:<14} {len(s['scenes']):>3} scenes {s['episodes']:>5} episodes{note}")
    typer.echo(f"wrote {out}")


@dataset_app.command("stats")
def dataset_stats(
    root: Optional[Path] = typer.Argument(None, help="Dataset folder (default: built on first use)."),
) -> None:
    """Summarise a dataset per split.

    Scenes, episodes, categories and difficulty mix per split (the paper's MS DEV mix beside ours); for the
    protocol splits also K, route lengths and how many instructions needed a spatial relation."""
    from rich.table import Table

    from biovln_ms.benchmark import PAPER_MS_DEV_DIFFICULTY, dataset_root
    from biovln_ms.episodes.dataset import EpisodeDataset

    root = dataset_root(root)
    ds = EpisodeDataset(root, robot=None)
    table = Table(title=f"{root} (robot {ds.robot}, agent radius {ds.agent_radius} m)")
    for col in (
        "split",
        "scenes",
        "episodes",
        "categories",
        "easy %",
        "medium %",
        "hard %",
        "start fallback",
        "paper",
    ):
        table.add_column(col)
    protocols = Table(title="protocol splits (lab protocols as multi-goal episodes)")
    for col in ("split", "protocols", "episodes", "mean K", "K = 2 / 3 / 4 / 5", "route m: mean (min-max)"):
        protocols.add_column(col)
    protocols.add_column("needing a relation: episodes % (visits %)")
    for name in ds.split_names():
        info = ds.manifest["splits"][name]
        if info.get("missing") and not info["files"]:
            table.add_row(name, "-", "-", "-", "-", "-", "-", "-", f"MISSING: {info['missing']}")
            continue
        st = ds.stats(name)
        d = st["difficulty"]
        paper = (
            ("paper " + " / ".join(f"{v}" for v in PAPER_MS_DEV_DIFFICULTY.values()))
            if name == "ms_dev"
            else ""
        )
        table.add_row(
            name,
            str(st["scenes"]),
            str(st["episodes"]),
            str(len(st["categories"])),
            f"{d['easy']}",
            f"{d['medium']}",
            f"{d['hard']}",
            str(st["start_fallback"]),
            paper,
        )
        if "protocol" in st:
            p, route = st["protocol"], st["protocol"]["route_length"]
            protocols.add_row(
                name,
                str(p["protocols"]),
                str(st["episodes"]),
                f"{p['mean_k']}",
                " / ".join(str(p["k"].get(k, 0)) for k in range(2, 6)),
                f"{route['mean']} ({route['min']}-{route['max']})",
                f"{p['needs_relation']} ({p['relation_visits']})",
            )
    Console(width=160).print(table)
    if protocols.row_count:
        Console(width=160).print(protocols)


@dataset_app.command("show")
def dataset_show(
    root: Optional[Path] = typer.Argument(None, help="Dataset folder (default: built on first use)."),
    split: str = typer.Option("ms_dev", help="Split name."),
    episode: Optional[str] = typer.Option(None, help="episode_id (default: the first episode)."),
    scene: Optional[str] = typer.Option(None, help="scene_id, when ids repeat across scenes."),
    out: Path = typer.Option(Path("episode.png"), "-o", "--out", help="PNG to write."),
) -> None:
    """Draw the map of one episode.

    Navigable islands, start and heading, goal, view points, shortest path."""
    from biovln_ms.benchmark import dataset_root
    from biovln_ms.episodes.dataset import EpisodeDataset
    from biovln_ms.scene.rules import scene_navigation
    from biovln_ms.scene.topdown import save_map

    root = dataset_root(root)
    ep, radius = _find_episode(root, split, episode, scene)
    spec = EpisodeDataset(root, verify=False, robot=None).spec(ep["scene_id"])
    typer.echo(f"wrote {save_map(spec, out, episode=ep, nav=scene_navigation(spec, radius))}")


DATASET_EXPORT_FORMATS = ("habitat",)


@dataset_app.command("export")
def dataset_export(
    fmt: str = typer.Argument(..., metavar="FORMAT", help=f"One of: {', '.join(DATASET_EXPORT_FORMATS)}."),
    split: str = typer.Option(..., "--split", "-s", help="Split to export."),
    out: Path = typer.Option(..., "-o", "--out", help="Folder to write into."),
    dataset: Optional[Path] = typer.Option(None, help="Dataset folder (default: built on first use)."),
) -> None:
    """Export a split as another tool's dataset.

    habitat: habitat-lab ObjectNav-v1 episodes (Y-up), the scenes as GLB and a habitat-sim scene dataset
    config."""
    from biovln_ms.benchmark import dataset_root
    from biovln_ms.bridges.habitat import export_habitat
    from biovln_ms.episodes.dataset import EpisodeDataset

    if fmt not in DATASET_EXPORT_FORMATS:
        raise BioVLNError(
            f"unknown export format '{fmt}'",
            field="FORMAT",
            fix=f"use one of: {', '.join(DATASET_EXPORT_FORMATS)}",
        )
    files = export_habitat(EpisodeDataset(dataset_root(dataset), robot=None), split, out)
    typer.echo(f"wrote {files[-1]}, {files[-2]} and {len(files) - 2} scene GLBs")


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
    env_id: str = typer.Option("BioVLN-OpFace-v0", "--env", help="Env id (a registered variant)."),
    fps: int = typer.Option(5, help="Frames per second."),
    lighting: str = _lighting_option(),
) -> None:
    """Record one episode as an MP4.

    The egocentric view beside a top-down map with trajectory, zones and goal."""
    from biovln_ms.benchmark import dataset_root
    from biovln_ms.record import record_episode

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
    out: Path = typer.Option(Path("results"), "--out", "-o", help="Results folder."),
    dataset: Optional[Path] = typer.Option(None, help="Dataset folder (default: built on first use)."),
    env_id: Optional[str] = typer.Option(
        None,
        "--env",
        help="Env variant, e.g. BioVLN-Centroid-v0 (default: BioVLN-OpFace-v0, or the method's own above).",
    ),
    workers: Optional[int] = typer.Option(None, help="Worker processes (default: one per core)."),
    max_episodes: Optional[int] = typer.Option(None, help="Only the first N episodes."),
    ray_address: Optional[str] = typer.Option(
        None,
        help="Run on Ray: 'local' (a local instance), 'auto' or "
        "'ray://host:port' (a cluster); --workers actors.",
    ),
    record: Optional[Path] = typer.Option(
        None, "--record", help="Record trajectories (TrajectoryRecorder) here."
    ),
    record_mode: str = typer.Option(
        "full", help="full (RGB PNGs + depth) or trace (positions/actions only)."
    ),
    checkpoint: Optional[Path] = typer.Option(
        None,
        help=f"Checkpoint of a learned method ({_LEARNED}): bc.pt for bc, a Stable-Baselines3 .zip for RL.",
    ),
    detector: Optional[str] = typer.Option(
        None, help="vlfm: 'gt' (default, simulator segmentation) or 'owlvit:/local/dir'."
    ),
    scorer: Optional[str] = typer.Option(
        None, help="vlfm: 'default' (packaged EfficientNet-Lite0 + MiniLM) or 'clip:/local/dir'."
    ),
    parser: Optional[str] = typer.Option(
        None, help="protocol_language: 'rule' (default, offline) or 'llm' (an LLM reads the instruction)."
    ),
    name: Optional[str] = typer.Option(None, help="Results folder name (default: the method)."),
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
    ),
    fresh_scene: bool = typer.Option(
        False,
        "--fresh-scene",
        help="Rebuild the scene at every episode (0.3-0.75 s each): outcomes that do not depend on the "
        "episodes a worker ran before (contacts; see the noise presets guide).",
    ),
) -> None:
    from biovln_ms.eval.harness import EvalConfig, evaluate
    from biovln_ms.eval.tables import headline

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
    "Every method on every benchmark split under every noise preset. Resumable (run it again after a "
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
    workers: Optional[int] = typer.Option(None, help="Worker processes (default: one per core)."),
    dataset: Optional[Path] = typer.Option(None, help="Dataset folder (default: built on first use)."),
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

    Goals from target_* markers (strategy 1) or from geometry + Eq. 1 (strategy 2)."""
    from biovln_ms.io_utils import atomic_write_text
    from biovln_ms.lsat.importer import import_glb
    from biovln_ms.lsat.name_map import load_name_map

    name_map = load_name_map(names) if names else None
    spec, rep = import_glb(glb, name=name, allow_external=allow_external, names=name_map)
    atomic_write_text(out, spec.to_json())
    rpath = report or out.with_suffix(".report.md")
    atomic_write_text(rpath, rep.to_markdown())
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

    if not (goals or lsat or usd):
        raise BioVLNError(
            "nothing to export", field="--goals/--lsat/--usd", fix="name at least one output file"
        )
    spec = load_spec(spec_path)
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
    import io
    import zipfile

    from biovln_ms.io_utils import atomic_write_bytes

    src = Path(__file__).parent / "lsat" / "blender_addon" / "biovln_lsat"
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", zipfile.ZIP_DEFLATED) as z:
        for f in sorted(src.glob("*.py")):
            z.writestr(zipfile.ZipInfo(f"biovln_lsat/{f.name}", (1980, 1, 1, 0, 0, 0)), f.read_bytes())
    typer.echo(
        f"wrote {atomic_write_bytes(out, buf.getvalue())} (install it from Blender's add-on preferences)"
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


@train_app.command("bc")
def train_bc_cmd(
    data: list[Path] = typer.Option(
        ..., "--data", help="Recording folder(s) of `eval --record` (repeatable)."
    ),
    out: Path = typer.Option(
        Path("ckpt/bc"), "--out", "-o", help="Folder for bc.pt, loss.png, history.json."
    ),
    epochs: int = typer.Option(500, help="Maximum epochs (the paper: 500)."),
    patience: int = typer.Option(50, help="Early-stopping patience in epochs (the paper: 50)."),
    batch_size: int = typer.Option(32, help="Batch size (the paper: 32)."),
    lr: float = typer.Option(1e-4, help="Adam learning rate (the paper: 1e-4)."),
    image_size: int = typer.Option(224, help="Input size in pixels (the paper: 224)."),
    max_minutes: Optional[float] = typer.Option(
        None, help="Wall-clock budget; stops after the epoch past it."
    ),
    pretrained: Optional[Path] = typer.Option(
        None, help="torchvision-layout ResNet-18 state dict to start from."
    ),
    seed: int = typer.Option(0, help="Seed of the split, the shuffling and the initial weights."),
) -> None:
    """Behavioural cloning on recorded trajectories.

    The paper's appendix, Table 17."""
    from biovln_ms.learning.bc import BCConfig, train_bc

    cfg = BCConfig(
        lr=lr,
        batch_size=batch_size,
        max_epochs=epochs,
        patience=patience,
        image_size=image_size,
        max_minutes=max_minutes,
        pretrained=str(pretrained) if pretrained else None,
        seed=seed,
    )
    r = train_bc(data, out, cfg, echo=typer.echo)
    typer.echo(
        f"best epoch {r.best_epoch} (val loss {r.best_val_loss:.4f}) of {r.epochs}, {r.stopped_by}, "
        f"{r.minutes:.1f} min -> {r.checkpoint}"
    )


def _train_rl(
    algo: str,
    timesteps: int,
    out: Optional[Path],
    n_envs: int,
    split: str,
    eval_split: str,
    eval_episodes: Optional[int],
    seed: int,
    ray_address: Optional[str],
    dataset: Optional[Path],
    sim_backend: Optional[str] = None,
) -> None:
    from biovln_ms.eval.learned import train_and_evaluate
    from biovln_ms.eval.tables import headline
    from biovln_ms.learning.rl import RLConfig

    cfg = RLConfig(
        algo=algo,
        timesteps=timesteps,
        n_envs=n_envs,
        split=split,
        seed=seed,
        ray_address=ray_address,
        sim_backend=sim_backend,
        eval_split=eval_split or None,
        eval_episodes=eval_episodes,
        dataset=str(dataset) if dataset else None,
    )
    r = train_and_evaluate(cfg, out or Path(f"runs/{algo}"), echo=typer.echo)
    if r.eval_summary:
        typer.echo(f"{algo} on {eval_split}: {headline(r.eval_summary)}")


def _rl_command(algo: str):
    def command(
        timesteps: int = typer.Option(200_000, "--timesteps", help="Environment steps to train for."),
        out: Optional[Path] = typer.Option(None, "--out", "-o", help=f"Run folder (default runs/{algo})."),
        n_envs: int = typer.Option(2, help="Parallel envs (one process or Ray actor each)."),
        split: str = typer.Option("train", help="Training split."),
        eval_split: str = typer.Option(
            "ms_val", help="Split evaluated through the harness afterwards ('' skips)."
        ),
        eval_episodes: Optional[int] = typer.Option(None, help="Only the first N evaluation episodes."),
        seed: int = typer.Option(0, help="Seed."),
        ray_address: Optional[str] = typer.Option(
            None, help="Envs on Ray actors: 'local', 'auto' or 'ray://host:port'."
        ),
        dataset: Optional[Path] = typer.Option(None, help="Dataset folder (default: built on first use)."),
        sim_backend: Optional[str] = typer.Option(
            None,
            help="One batched env of --n-envs sub-envs on this backend (physx_cuda on a GPU; physx_cpu "
            "allows one) instead of one process per env.",
        ),
    ) -> None:
        _train_rl(
            algo,
            timesteps,
            out,
            n_envs,
            split,
            eval_split,
            eval_episodes,
            seed,
            ray_address,
            dataset,
            sim_backend,
        )

    command.__doc__ = (
        f"{algo.upper()} with Stable-Baselines3 on the RL env.\n\n{RL_ENV}: TensorBoard logs, checkpoints, "
        "learning curve, then evaluation through the harness."
    )
    return command


def _register_rl_commands() -> None:
    for algo in SB3_CONTROL_MODES:
        train_app.command(algo)(_rl_command(algo))


_register_rl_commands()


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

    spec = load_spec(spec_path)
    files = export_nav2(spec, out, resolution)
    typer.echo(f"wrote {len(files)} files to {out}: {', '.join(f.name for f in files)}")


#: what a user can cause and fix: printed as one line, exit status 2
USER_ERRORS = (BioVLNError, OSError)


def user_error_line(e: BaseException) -> str:
    """The one line a user error prints: a BioVLNError as it says; a file the command could not read or
    write (too long a name, no permission, a missing folder) with the path and the system's reason."""
    if isinstance(e, OSError):
        where = e.filename if e.filename is not None else "a file"
        return f"{where}: {e.strerror or e} (fix: check the path, its folder and its permissions)"
    return str(e)


@app.callback()
def _plugins(
    plugin: list[str] = typer.Option(
        [],
        "--plugin",
        help="A plugin module (or .py file) to import first: your methods, measures, sensors, variants, "
        "templates and instruments (repeatable; entry points of the group biovln_ms.plugins load always).",
    ),
) -> None:
    load_plugins(plugin)


def _plugin_args(argv: list[str]) -> list[str]:
    """The ``--plugin`` values before the command (loaded before the commands read the registries)."""
    out = []
    for i, arg in enumerate(argv):
        if arg == "--plugin" and i + 1 < len(argv):
            out.append(argv[i + 1])
        elif arg.startswith("--plugin="):
            out.append(arg.split("=", 1)[1])
    return out


@app.command("list")
def list_cmd(
    what: str = typer.Argument(
        "methods", help="methods, variants, measures, sensors, templates or instruments."
    ),
) -> None:
    """List what is registered (plugins' entries included).

    Methods, env variants, measures (with their record key), sensors, scene templates or instruments."""
    from biovln_ms.catalog import load_catalog
    from biovln_ms.metrics.measures import measure_names, measure_type
    from biovln_ms.scene.templates import template_names
    from biovln_ms.variants import VARIANTS

    if what == "sensors":
        from biovln_ms.tasks.sensors import SENSORS  # the simulator layer: sapien, torch

        rows = list(SENSORS)
    else:
        rows = {
            "methods": lambda: [_method_line(m) for m in report_methods()],
            "variants": lambda: list(VARIANTS),
            "measures": lambda: [
                n + (f" -> {measure_type(n).metric.key}" if measure_type(n).metric else "")
                for n in measure_names()
            ],
            "templates": template_names,
            "instruments": lambda: load_catalog().names(),
        }.get(what, lambda: None)()
    if rows is None:
        raise BioVLNError(
            f"nothing called '{what}' is listed",
            field="what",
            fix="use methods, variants, measures, sensors, templates or instruments",
        )
    for row in rows:
        typer.echo(row)


def main() -> None:
    """Entry point: user-facing errors print as one clear line, not a traceback."""
    try:
        load_plugins(_plugin_args(sys.argv[1:]))
        app()
    except USER_ERRORS as e:
        console.print(f"[bold red]error:[/] {escape(user_error_line(e))}", highlight=False, soft_wrap=True)
        sys.exit(2)


if __name__ == "__main__":
    main()
