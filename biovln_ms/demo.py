"""The README demo: what the platform can show so far, written as PNG, JSON and Markdown."""

from __future__ import annotations

from pathlib import Path

from biovln_ms.catalog import load_catalog
from biovln_ms.episode_video import record_episode
from biovln_ms.episodes.generator import EpisodeSampler
from biovln_ms.eval.harness import DEFAULT_ENV, EvalConfig, evaluate
from biovln_ms.metrics.measures import measure_type
from biovln_ms.render.asset_preview import contact_sheet
from biovln_ms.render.scene_view import render_overview
from biovln_ms.scene.generator import generate_scene
from biovln_ms.scene.rules import scene_navigation
from biovln_ms.scene.spec import save_spec
from biovln_ms.splits import FOUR_CATEGORIES
from biovln_ms.variants import VARIANTS


def run_demo(out_dir: Path, echo=print, lighting: str = "quality") -> dict[str, Path]:
    """Asset contact sheet and catalog table; the held-out scene lab_s150_v0 as spec, SAPIEN view and a map
    with one episode (start, goal, view points, exact shortest path); the oracle run on MS VAL episode 0 as
    an MP4 (egocentric view beside the map) with its metrics, the renders under the lighting preset
    ``lighting``; then oracle and frontier evaluated on MS VAL and the report (tables with the paper's
    numbers, plots, renders, one MP4)."""
    from biovln_ms.scene.topdown import save_map

    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    cat = load_catalog()
    files: dict[str, Path] = {"sheet": out_dir / "asset_sheet.png"}
    renders = {r.name: r for r in contact_sheet(files["sheet"], cat, lighting=lighting)}
    lines = [
        "# BioVLN-MS catalog (paper Table 2 + Tables 6, 8)",
        "",
        "| asset | dimensions (m) | placement | face | d_half | delta | r | colours front / back |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for a in cat.assets():
        r = renders[a.name]
        dims = " x ".join(f"{d:.2f}" for d in a.dimensions)
        lines.append(
            f"| {a.name} | {dims} | {a.placement} | {a.face or '-'} | {a.d_half} | {a.approach_distance} | "
            f"{a.success_radius} | {r.front_colors} / {r.back_colors} |"
        )
    spec = generate_scene("single_room", 150, required_categories=FOUR_CATEGORIES)
    nav = scene_navigation(spec)
    episode = EpisodeSampler(spec, nav).episodes(1, seed=0)[0]
    files["spec"] = save_spec(spec, out_dir / f"{spec.name}.json")
    files["map"] = save_map(spec, out_dir / f"{spec.name}_episode.png", episode=episode, nav=nav)
    files["render"] = render_overview(spec, out_dir / f"{spec.name}_view.png", lighting=lighting)
    info = episode["info"]
    lines += [
        "",
        f"# Scene {spec.name}, episode 0",
        "",
        "| target | start | goal | geodesic (m) | euclidean (m) | difficulty |",
        "|---|---|---|---|---|---|",
        f"| {episode['object_id']} | {episode['start_position'][:2]} | "
        f"{episode['goals'][0]['position'][:2]} | "
        f"{info['geodesic_distance']:.3f} | {info['euclidean_distance']:.3f} | {info['difficulty']} |",
    ]

    files["video"] = out_dir / "ms_val_episode0_oracle.mp4"
    m = record_episode(files["video"], split="ms_val", episode=0, policy="oracle", lighting=lighting)
    lines += [
        "",
        "# Oracle on MS VAL episode 0 (BioVLN-OpFace-v0, SAPIEN physics, CPU render)",
        "",
        *_metrics_table(m),
    ]
    files["table"] = out_dir / "demo.md"
    files["table"].write_text("\n".join(lines) + "\n")

    # The main job: evaluate oracle and frontier on MS VAL and write the report.
    from biovln_ms.eval.report import write_report

    for method in ("oracle", "frontier"):
        evaluate(EvalConfig(method, "ms_val", str(out_dir / "results")), echo=echo)
    files["report"] = write_report(
        out_dir / "results", out_dir / "report", videos=1, hard_figures=1, echo=echo
    )
    for k, p in files.items():
        echo(f"wrote {p}")
    return files


def _metrics_table(info: dict) -> list[str]:
    """The episode's end values of the benchmark variant's recorded metrics, one column each."""
    cols = []
    for name in VARIANTS[DEFAULT_ENV].measures:
        metric = measure_type(name).metric
        if metric is not None and metric.at == "end" and name in info:
            cols.append((metric.key, info[name]))  # the episode's value, as its record holds it
    cells = [f"{v:.3f}" if isinstance(v, float) else str(v) for _, v in cols]
    return [
        "| " + " | ".join(h for h, _ in cols) + " |",
        "|" + "---|" * len(cols),
        "| " + " | ".join(cells) + " |",
    ]
