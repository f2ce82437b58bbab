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


def _measured(runs: list[dict], section: str, *keys: str) -> list[tuple[dict, ...]]:
    """Per run that measured every one of ``keys`` in ``section`` (no error, not blocked), its entries, so
    that a ratio divides figures of the same run."""
    out = []
    for r in runs:
        es = tuple(r.get(section, {}).get(k) for k in keys)
        if all(isinstance(e, dict) and "error" not in e and "blocked" not in e for e in es):
            out.append(es)
    return out


def _errors(runs: list[dict], section: str, key: str) -> list[str]:
    """The errors ``section``/``key`` recorded, one per run that failed it."""
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
    cpu = _measured(runs, "cpu_ref", "state_physx_cpu", "pickcube_physx_cpu")
    if cpu:
        rows.append(
            [
                "state only, physx_cpu, 1 env",
                f"{joined(s['steps_per_s'] for s, _ in cpu)} steps/s",
                f"PickCube-v1 {joined(p['steps_per_s'] for _, p in cpu)} "
                f"({joined((s['steps_per_s'] / p['steps_per_s'] for s, p in cpu), X)})",
            ]
        )
    rgbd = _measured(runs, "cpu_ref", "rgbd128_physx_cpu")
    if rgbd:
        rows.append(
            [
                "RGB-D 128×128, physx_cpu, rendered by the GPU",
                f"{joined(e['steps_per_s'] for (e,) in rgbd)} steps/s",
                "–",
            ]
        )
    for size in ("640x480", "128x128"):
        label = size.replace("x", "×")
        fast = _measured(runs, "lighting", f"fast_{size}")
        if fast:
            rows.append(
                [
                    f"RGB-D {label} step, `fast` lighting",
                    f"{joined((e['ms_per_step'] for (e,) in fast), '{:.2f}')} ms",
                    f"raw SAPIEN frame {joined((e['raw_ms_per_frame'] for (e,) in fast), '{:.2f}')} ms "
                    f"({joined((e['raw_ms_per_frame'] / e['ms_per_step'] for (e,) in fast), X)} raw speed)",
                ]
            )
        both = _measured(runs, "lighting", f"quality_{size}", f"fast_{size}")
        if both:
            rows.append(
                [
                    f"RGB-D {label} step, `quality` lighting",
                    f"{joined((q['ms_per_step'] for q, _ in both), '{:.2f}')} ms",
                    f"{joined((q['ms_per_step'] / f['ms_per_step'] for q, f in both), X)} `fast`",
                ]
            )
    depth = _measured(runs, "depth_pack", "640x480")
    if depth:
        same = all(e["depth_identical"] and e["segmentation_identical"] for (e,) in depth)
        rows.append(
            [
                "640×480 depth + segmentation, depth-only shader pack",
                f"{joined(e['depth+segmentation_steps_per_s'] for (e,) in depth)} steps/s",
                f"minimal pack {joined(e['rgb+depth+segmentation_steps_per_s'] for (e,) in depth)} steps/s; "
                f"depth and segmentation identical {same}",
            ]
        )
    noise = _measured(runs, "noise", "640x480")
    if noise:
        matches = all(
            e["realistic_semantic_category_matches"] and e["ideal_semantic_category_matches"]
            for (e,) in noise
        )
        rows.append(
            [
                "640×480 RGB-D + segmentation, `realistic` noise",
                f"{joined(e['realistic_steps_per_s'] for (e,) in noise)} steps/s",
                f"`ideal` {joined(e['ideal_steps_per_s'] for (e,) in noise)} "
                f"({joined((e['realistic_steps_per_s'] / e['ideal_steps_per_s'] for (e,) in noise), X)}); "
                f"images on {noise[-1][0]['realistic_devices']['rgb']}, goal category per pixel matches "
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
    runs = []
    for p in args.runs:
        try:
            runs.append(json.loads(p.read_text()))
        except (OSError, ValueError) as e:
            ap.error(
                f"{p}: not a run's gpu_speed.json ({type(e).__name__}: {e}); pass the files run_all.sh wrote"
            )
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
