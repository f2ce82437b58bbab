"""The operating point ``perception train`` would choose for a detector's weights: its validation frames'
mean precision, mean recall and harmonic mean at each instance score of ``SCORE_GRID``, under the trainer's
rule (``biovln_ms.perception.train_detector.operating_points``), beside the ``min_score`` in the weights'
header.

    python benchmarks/detector_operating_point.py --frame-data data/frames [--weights FILE] [--seed 0]

The validation frames are the ones training held back for ``--seed`` (a tenth of the ``train`` part's
groups). The table goes to ``docs/data/perception/operating_points.json``.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import torch

from biovln_ms.measured import docs_data_dir, write_table
from biovln_ms.perception import segmenter as S
from biovln_ms.perception import train_detector as T


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--frame-data", type=Path, required=True, help="the frames the weights were trained on")
    ap.add_argument("--weights", type=Path, default=None, help="default: the shipped weights")
    ap.add_argument("--seed", type=int, default=0, help="the training seed (which frames validated)")
    ap.add_argument("--data-out", type=Path, default=docs_data_dir() / "perception" / "operating_points.json")
    args = ap.parse_args()
    torch.set_num_threads(1)
    images, anns = T.read_part(args.frame_data, "train")
    val = [im for im in images if T.is_validation(im, args.seed)]
    frames = [T.read_frame(args.frame_data, im, anns[im["id"]]) for im in val]
    seg = S.Segmenter(args.weights) if args.weights else S.Segmenter()
    shipped, seg.min_score = seg.min_score, 0.0  # every instance: the grid filters them
    cats = S.goal_categories()
    points = T.operating_points(T.frame_instances(seg, val, frames, anns), cats)
    chosen = T.choose_min_score(points)
    rows = [
        [
            p["min_score"],
            p["mean_precision"],
            p["mean_recall"],
            p["f1"],
            "chosen" if p["min_score"] == chosen else "",
        ]
        for p in points
    ]
    notes = [
        f"{len(val)} validation frames of {args.frame_data.name} (seed {args.seed}); weights "
        f"{seg.path.name if seg.path else 'shipped'}, header min_score {shipped}; chosen now: {chosen}.",
        "The weights as stored (the shipped file is fp16; training chooses on its fp32 net).",
    ]
    for r in rows:
        print(*r)
    print(notes[0])
    columns = ["min_score", "mean precision", "mean recall", "harmonic mean", "the trainer's choice"]
    write_table(
        args.data_out, "The detector's operating points under the trainer's rule", columns, rows, notes
    )


if __name__ == "__main__":
    main()
