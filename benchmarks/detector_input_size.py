"""The detector's recall, precision and cost against the size of the net's input, on the same frames.

    python benchmarks/detector_input_size.py --run RUN_DIR [--run RUN_DIR ...]

Each ``RUN_DIR`` is a ``perception train`` output folder (``train.json``, ``detector.safetensors``) in which
``perception evaluate --weights RUN_DIR/detector.safetensors -o RUN_DIR/eval.json`` has been run on the
frames it trained on. One column per run: the input size, training minutes, detection time at 640x480,
mean precision and recall on the held-out scenes and looks per condition (matched by mask IoU; under
``fast`` lighting and ideal noise, the goal's condition, also by box IoU), and each category's recall on
the held-out scenes under that condition, by mask and by box. The table goes to
``docs/data/perception/detector_input_size.json``.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from biovln_ms.measured import docs_data_dir, write_table
from biovln_ms.perception.segmenter import goal_categories

CONDITIONS = ("fast/ideal", "fast/realistic", "quality/ideal", "quality/realistic")
PARTS = ("test_scenes", "test_looks")
GOAL = "fast/ideal"  # the goal is judged here


def _run(folder: Path) -> tuple[dict, dict]:
    train = json.loads((folder / "train.json").read_text())
    ev = json.loads((folder / "eval.json").read_text())
    return train, ev


def column(train: dict, ev: dict) -> list:
    """One run's values, in the order of :func:`row_names`."""
    out = [
        "x".join(map(str, train["input_size"])),
        train["epochs_run"],
        round(train["seconds"] / 60, 1),
        round(train["cpu_seconds"] / 60, 1),
        train["min_score"],
        ev["detect_ms_640x480"]["median"],
        ev["detect_ms_640x480"]["p90"],
    ]
    for cond in CONDITIONS:
        for part in PARTS:
            s = ev["results"][cond][part]
            out.append(f"{s['mean_precision']:.2f} / {s['mean_recall']:.2f} (frames {s['frames']})")
    for part in PARTS:
        s = ev["results_box"][GOAL][part]
        out.append(f"{s['mean_precision']:.2f} / {s['mean_recall']:.2f}")
    cats, boxes = (ev[k][GOAL]["test_scenes"]["categories"] for k in ("results", "results_box"))
    for c in goal_categories():
        row = cats[c]
        out.append(
            f"{row['recall']:.2f} / {boxes[c]['recall']:.2f} (n {row['instances']})"
            if row["instances"]
            else "-"
        )
    return out


def row_names() -> list[str]:
    names = ["input (W x H)", "epochs", "training loop, wall (min)", "training loop, CPU (min)"]
    names += ["operating point (min_score)"]
    names += ["detection at 640x480, median (ms)", "detection at 640x480, p90 (ms)"]
    names += [f"{cond}, {part}: mean precision / recall" for cond in CONDITIONS for part in PARTS]
    names += [f"{GOAL}, {part}, matched by box: mean precision / recall" for part in PARTS]
    names += [f"recall by mask / by box, {c} ({GOAL}, test_scenes)" for c in goal_categories()]
    return names


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--run", type=Path, action="append", required=True, help="a trained and evaluated run")
    ap.add_argument(
        "--data-out", type=Path, default=docs_data_dir() / "perception" / "detector_input_size.json"
    )
    args = ap.parse_args()
    runs = [_run(r) for r in args.run]
    frames = {json.dumps(ev["frames"], sort_keys=True) for _, ev in runs}
    if len(frames) != 1:
        raise SystemExit("error: the runs were evaluated on different frames; evaluate them on the same set")
    cols = [column(t, e) for t, e in runs]
    rows = [[name, *(c[i] for c in cols)] for i, name in enumerate(row_names())]
    for r in rows:
        print(*r, sep=" | ")
    first = runs[0][1]
    notes = [
        f"Frames: {first['frames']['source']} (seed {first['frames']['seed']}, "
        f"{'x'.join(map(str, first['frames']['size']))}); every run trained with seed "
        f"{', '.join(str(t['seed']) for t, _ in runs)} on its train part, evaluated on the held-out parts.",
        f"Detection: one target mask at 640x480 on {first['threads']} threads, median of "
        f"{first['detect_ms_640x480']['n']} frames.",
    ]
    write_table(
        args.data_out,
        "The detector against its input size, on the same frames",
        ["measure", *(f"run {i + 1}" for i in range(len(runs)))],
        rows,
        notes,
    )


if __name__ == "__main__":
    main()
