"""Matching a frame's detections to its annotated instances, and the per-category tally of an evaluation
(COCO's AP50 rule: a detection matches the unmatched annotation of its category it overlaps most, if their
IoU is at least :data:`IOU_MATCH`); :mod:`~.evaluate_detector` and training's validation share it.

The IoU is of the masks (the ``mask`` rule, COCO's segmentation AP) or of their bounding boxes (``box``,
COCO's detection AP): a thin object, such as the pipette stand's rails, is annotated as its outline, which
a region of the label map covers as a filled blob, a miss by mask and a match by box."""

from __future__ import annotations

from collections import Counter

import numpy as np

from biovln_ms.metrics.intervals import wilson_interval
from biovln_ms.perception import segmenter as S
from biovln_ms.perception.frames import decode_mask

IOU_MATCH = 0.5
#: what the IoU of a detection and an annotated instance is taken of (:func:`match_frame`)
MATCH_RULES = ("mask", "box")
CONFIDENCE = 0.95
#: a detection "covers" an annotated instance when it holds at least this share of its pixels
COVER = 0.5
#: why an annotated instance went unmatched, tested in this order (:func:`miss_cause`)
MISS_CAUSES = {
    "merged": "a detection of its category covers it and another annotated one of its category (any size)",
    "oversized": "a detection of its category covers it but spills past it (IoU under the match rule)",
    "partial": "detections of its category overlap it, none covering half of it",
    "dropped": "the net's commonest label on it is its category, in regions under the score or size floor",
    "other category": "the net's commonest label on it is another category (named in confused_with)",
    "background": "the net's commonest label on it is background",
}


def wilson(k: int, n: int, confidence: float = CONFIDENCE) -> list[float] | None:
    """:func:`~biovln_ms.metrics.intervals.wilson_interval` of k in n, to 4 decimals; None for n = 0."""
    if n == 0:
        return None
    return [round(float(x), 4) for x in wilson_interval(k, n, confidence)]


class Tally:
    """Per-category counts of one evaluation."""

    def __init__(self, categories: list[str], causes: bool = False, rule: str = "mask") -> None:
        if rule not in MATCH_RULES:
            raise ValueError(f"match rule '{rule}' is not one of {MATCH_RULES}")
        self.categories, self.rule = list(categories), rule
        #: per category, the misses by cause and the categories the net took them for (``causes``)
        self.causes = causes
        self.misses = {c: Counter() for c in categories}
        self.confused = {c: Counter() for c in categories}
        z = dict.fromkeys(categories, 0)
        self.gt, self.pred, self.tp = dict(z), dict(z), dict(z)
        self.iou_sum = dict.fromkeys(categories, 0.0)
        self.inter, self.union = dict(z), dict(z)
        self.frames = 0

    def summary(self) -> dict:
        rows = {}
        for c in self.categories:
            gt, pred, tp = self.gt[c], self.pred[c], self.tp[c]
            rows[c] = {
                "instances": gt,
                "detections": pred,
                "matched": tp,
                "precision": round(tp / pred, 4) if pred else None,
                "precision_ci": wilson(tp, pred),
                "recall": round(tp / gt, 4) if gt else None,
                "recall_ci": wilson(tp, gt),
                f"{self.rule}_iou": round(self.iou_sum[c] / tp, 4) if tp else None,
            }
            if self.rule == "mask":  # the category's pixels: the same under either rule, kept once
                rows[c]["pixel_iou"] = round(self.inter[c] / self.union[c], 4) if self.union[c] else None
            if self.causes:
                rows[c]["misses"] = {k: self.misses[c][k] for k in MISS_CAUSES if self.misses[c][k]}
                rows[c]["confused_with"] = dict(self.confused[c].most_common())

        def mean(key: str) -> float | None:
            vals = [r[key] for r in rows.values() if r[key] is not None]
            return round(float(np.mean(vals)), 4) if vals else None

        tp, gt, pred = sum(self.tp.values()), sum(self.gt.values()), sum(self.pred.values())
        return {
            "frames": self.frames,
            "mean_precision": mean("precision"),
            "mean_recall": mean("recall"),
            **({"mean_pixel_iou": mean("pixel_iou")} if self.rule == "mask" else {}),
            "pooled_precision": round(tp / pred, 4) if pred else None,
            "pooled_recall": round(tp / gt, 4) if gt else None,
            "categories": rows,
        }


def miss_cause(
    j: int, gts: list[tuple[str, np.ndarray, bool]], preds: list[S.Instance], net: np.ndarray,
    categories: list[str],
) -> tuple[str, str | None]:  # fmt: skip
    """Why annotated instance ``gts[j]`` went unmatched (a :data:`MISS_CAUSES` key), and the category the
    net took it for (``other category`` only). ``net``: the net's label map at the frame's size."""
    c, m, _ = gts[j]
    area = m.sum()
    mine = [p for p in preds if p.category == c]
    covers = [np.logical_and(m, p.mask).sum() / area for p in mine]
    if covers and max(covers) >= COVER:
        best = mine[int(np.argmax(covers))].mask
        others = (o for k, (oc, o, _) in enumerate(gts) if k != j and oc == c)
        if any(np.logical_and(o, best).sum() >= COVER * o.sum() for o in others):
            return "merged", None
        return "oversized", None
    if any(covers):
        return "partial", None
    top = int(np.argmax(np.bincount(net[m], minlength=len(categories) + 1)))
    if top == categories.index(c) + 1:
        return "dropped", None
    return ("background", None) if top == 0 else ("other category", categories[top - 1])


def box_of(mask: np.ndarray) -> tuple[int, int, int, int]:
    """The pixel box (x0, y0, x1, y1), end exclusive, of a mask's pixels; (0, 0, 0, 0) for an empty mask."""
    ys, xs = np.any(mask, axis=1), np.any(mask, axis=0)
    if not ys.any():
        return 0, 0, 0, 0
    y0, y1 = np.flatnonzero(ys)[[0, -1]]
    x0, x1 = np.flatnonzero(xs)[[0, -1]]
    return int(x0), int(y0), int(x1) + 1, int(y1) + 1


def box_iou(a: tuple[int, int, int, int], b: tuple[int, int, int, int]) -> float:
    """IoU of two (x0, y0, x1, y1) boxes."""
    w = min(a[2], b[2]) - max(a[0], b[0])
    h = min(a[3], b[3]) - max(a[1], b[1])
    inter = max(w, 0) * max(h, 0)
    union = (a[2] - a[0]) * (a[3] - a[1]) + (b[2] - b[0]) * (b[3] - b[1]) - inter
    return inter / union if union > 0 else 0.0


def annotated(
    anns: list[dict], categories: list[str], shape: tuple[int, int]
) -> list[tuple[str, np.ndarray, bool]]:
    """A frame's COCO annotations as (category, mask, counted) each, decoded once for every tally they
    go to; ``counted``: at least :func:`~biovln_ms.perception.segmenter.min_pixels` for a frame of
    ``shape`` (smaller ones are ignored)."""
    smallest = S.min_pixels(*shape)
    return [
        (categories[a["category_id"] - 1], decode_mask(a["segmentation"]), a["area"] >= smallest)
        for a in anns
    ]


def match_frame(
    tally: Tally,
    preds: list[S.Instance],
    gts: list[tuple[str, np.ndarray, bool]],
    categories: list[str],
    labels: np.ndarray,
    net: np.ndarray | None = None,
) -> None:
    """Add one frame: detections ``preds``, its annotated instances ``gts`` (:func:`annotated`) and
    semantic ``labels`` (0: background, 1 + category index); with ``net``, the net's label map at the
    frame's size, each counted miss's cause (:func:`miss_cause`) for a tally that keeps them."""
    tally.frames += 1
    for c, _, counted in gts:
        tally.gt[c] += counted
    used = [False] * len(gts)
    by_box = tally.rule == "box"
    boxes = [box_of(m) for _, m, _ in gts] if by_box else []
    for p in sorted(preds, key=lambda p: -p.score):
        best, best_iou = None, IOU_MATCH
        pbox = box_of(p.mask) if by_box else None
        for j, (c, m, _) in enumerate(gts):
            if c != p.category or used[j]:
                continue
            if by_box:
                iou = box_iou(boxes[j], pbox)
            else:
                inter = np.logical_and(m, p.mask).sum()
                iou = inter / (m.sum() + p.mask.sum() - inter)
            if iou >= best_iou:
                best, best_iou = j, iou
        if best is not None:
            used[best] = True
            if gts[best][2]:
                tally.pred[p.category] += 1
                tally.tp[p.category] += 1
                tally.iou_sum[p.category] += float(best_iou)
        else:
            tally.pred[p.category] += 1
    if tally.causes and net is not None:
        for j, (c, _, counted) in enumerate(gts):
            if counted and not used[j]:
                cause, taken_for = miss_cause(j, gts, preds, net, categories)
                tally.misses[c][cause] += 1
                if taken_for:
                    tally.confused[c][taken_for] += 1
    if by_box:  # the pixel statistics are the mask rule's
        return
    for k, c in enumerate(categories):
        mine = np.zeros(labels.shape, bool)
        for p in preds:
            if p.category == c:
                mine |= p.mask
        truth = labels == k + 1
        tally.inter[c] += int(np.logical_and(mine, truth).sum())
        tally.union[c] += int(np.logical_or(mine, truth).sum())
