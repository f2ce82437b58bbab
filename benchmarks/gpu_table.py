"""The docs' table of runs of ``benchmarks/gpu_speed.py`` on a lent GPU machine (what ran there: physics on
the CPU, rendering on the GPU, while the PhysX GPU library is missing there).

    python benchmarks/gpu_table.py docs/data/gpu/h200_run1.json docs/data/gpu/h200_run2.json ...

Each argument is a run's ``gpu_speed.json`` (``scripts/gpu/run_all.sh`` writes it to ``$OUT``; keep it in
``docs/data/gpu/``). A row gives every run that measured it, in the order given, separated by " / "; a
section that errored is shown as its error. Writes ``docs/data/benchmarks/gpu_speed.json`` (``--data-out``).
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from biovln_ms.measured import docs_data_dir, write_table


def _entries(runs: list[dict], section: str, key: str) -> list[dict]:
    """``runs``' entries for ``section``/``key`` that were measured (no error, not blocked)."""
    out = []
    for r in runs:
        e = r.get(section, {}).get(key)
        if isinstance(e, dict) and "error" not in e and "blocked" not in e:
            out.append(e)
    return out


def _errors(runs: list[dict], section: str, key: str) -> list[str]:
    return [
        f"run {i + 1}: {e['error']}"
        for i, r in enumerate(runs)
        if isinstance(e := r.get(section, {}).get(key), dict) and "error" in e
    ]


X = "{:.2f}×"  # a ratio's format


def joined(values, fmt="{:,.0f}") -> str:
    return " / ".join(fmt.format(v) for v in values) or "–"


def rows_of(runs: list[dict]) -> list[list[str]]:
    rows = []
    state = _entries(runs, "cpu_ref", "state_physx_cpu")
    pick = _entries(runs, "cpu_ref", "pickcube_physx_cpu")
    rgbd = _entries(runs, "cpu_ref", "rgbd128_physx_cpu")
    if state:
        rows.append(
            [
                "state only, physx_cpu, 1 env",
                f"{joined(e['steps_per_s'] for e in state)} steps/s",
                f"PickCube-v1 {joined(e['steps_per_s'] for e in pick)} "
                f"({joined((a['steps_per_s'] / b['steps_per_s'] for a, b in zip(state, pick)), '{:.2f}×')})",
            ]
        )
    if rgbd:
        rows.append(
            [
                "RGB-D 128×128, physx_cpu, rendered by the GPU",
                f"{joined(e['steps_per_s'] for e in rgbd)} steps/s",
                "–",
            ]
        )
    light = {
        k: _entries(runs, "lighting", k)
        for k in ("fast_640x480", "fast_128x128", "quality_640x480", "quality_128x128")
    }
    for size in ("640x480", "128x128"):
        fast = light[f"fast_{size}"]
        if fast:
            rows.append(
                [
                    f"RGB-D {size.replace('x', '×')} step, `fast` lighting",
                    f"{joined((e['ms_per_step'] for e in fast), '{:.2f}')} ms",
                    f"raw SAPIEN frame {joined((e['raw_ms_per_frame'] for e in fast), '{:.2f}')} ms "
                    f"({joined((e['raw_ms_per_frame'] / e['ms_per_step'] for e in fast), X)} of raw speed)",
                ]
            )
        q = light[f"quality_{size}"]
        if q and fast:
            rows.append(
                [
                    f"RGB-D {size.replace('x', '×')} step, `quality` lighting",
                    f"{joined((e['ms_per_step'] for e in q), '{:.2f}')} ms",
                    f"{joined((a['ms_per_step'] / b['ms_per_step'] for a, b in zip(q, fast)), X)} `fast`",
                ]
            )
    for e in _entries(runs, "depth_pack", "640x480"):
        rows.append(
            [
                "640×480 depth + segmentation, depth-only shader pack",
                f"{e['depth+segmentation_steps_per_s']:,.0f} steps/s",
                f"minimal pack {e['rgb+depth+segmentation_steps_per_s']:,.0f} steps/s; depth identical "
                f"{e['depth_identical']}, segmentation identical {e['segmentation_identical']}",
            ]
        )
    noise = _entries(runs, "noise", "640x480")
    if noise:
        matches = all(
            e["realistic_semantic_category_matches"] and e["ideal_semantic_category_matches"] for e in noise
        )
        rows.append(
            [
                "640×480 RGB-D + segmentation, `realistic` noise",
                f"{joined(e['realistic_steps_per_s'] for e in noise)} steps/s",
                f"`ideal` {joined(e['ideal_steps_per_s'] for e in noise)} "
                f"({joined((e['realistic_steps_per_s'] / e['ideal_steps_per_s'] for e in noise), X)}); "
                f"images on {noise[-1]['realistic_devices']['rgb']}, goal category per pixel matches "
                f"{matches}",
            ]
        )
    blocked = sorted({s for r in runs for s, v in r.items() if isinstance(v, dict) and "blocked" in v})
    if blocked:
        rows.append(
            ["physx_cuda sections", "blocked", f"no PhysX GPU library on the machine: {', '.join(blocked)}"]
        )
    return rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("runs", nargs="+", type=Path)
    ap.add_argument("--data-out", type=Path, default=docs_data_dir() / "benchmarks" / "gpu_speed.json")
    args = ap.parse_args()
    runs = [json.loads(p.read_text()) for p in args.runs]
    meta = next((r["meta"] for r in runs if isinstance(r.get("meta"), dict) and "gpu" in r["meta"]), {})
    measured_on = (
        f"{meta.get('gpu', '?')} (driver {meta.get('driver', '?')}), {meta.get('cpu', '?')}, Python "
        f"{meta.get('python', '?')}, torch {meta.get('torch', '?')}, sapien {meta.get('sapien', '?')}; "
        f"Vulkan: {meta.get('vulkan', '?')}"
    )
    notes = [
        "Where a row has several figures, they are those of the runs that measured it, in this order: "
        + "; ".join(f"{p.name}: {', '.join(s for s in r if s != 'meta')}" for p, r in zip(args.runs, runs)),
        *[
            f"{s}: {msg}"
            for s, k in (("depth_pack", "640x480"), ("noise", "640x480"))
            for msg in _errors(runs, s, k)
        ],
    ]
    write_table(
        args.data_out,
        "BioVLN-OpFace-v0 on a GPU machine (physics on the CPU, rendering on the GPU)",
        ["measure", "this version", "reference in the same run"],
        rows_of(runs),
        notes,
        provenance="benchmarks/gpu_speed.py on a lent GPU machine, through scripts/gpu/run_all.sh",
        measured_on=measured_on,
    )


if __name__ == "__main__":
    main()
