"""Can an image-text model tell which instrument it sees? (the paper's Table 8 question)

Every goal category is rendered at its three Zone-3 views (:func:`~biovln_ms.render.goal_views.goal_views`:
the Eq. 1 goal and the goal turned ±15° about the object, the head camera's 640x480 frame, 0.88 m high,
looking at the object's centre; :func:`~biovln_ms.render.goal_views.showcase_scenes` picks the scenes)
under the lighting presets ``fast`` (unshadowed, that of every released result) and ``quality``. Each
frame is scored against the prompts of all goal categories (VLFM's prompt with the catalog's display name,
as the VLFM baseline asks); a view is recognised at top-k when its own category's prompt is among the k best.

    python benchmarks/recognition.py [--clip DIR | --detector trained[:FILE]] [--sheet PNG] [--data-out JSON]

The scorer is the shipped offline one (``ClassifierTextScorer``: EfficientNet-Lite0's ImageNet classes
projected onto the prompt by MiniLM sentence embeddings), or with ``--clip DIR`` a CLIP model saved in DIR
(``CLIPScorer``; nothing is downloaded), or with ``--detector`` the trained goal-category detector
(:class:`DetectorRecognizer`: a category's score is how much of the frame's centre its instances cover,
weighted by their confidence). The table goes to ``docs/data/benchmarks/recognition.json``
(``_clip`` / ``_detector`` added with ``--clip`` / ``--detector``) and the contact sheet of the renders
with their scores to ``docs/images/recognition_sheet.png`` (the same suffixes).
"""

from __future__ import annotations

import argparse
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from biovln_ms.catalog import load_catalog
from biovln_ms.measured import docs_data_dir, load_table, write_table
from biovln_ms.perception.detectors import TrainedDetector, make_detector
from biovln_ms.perception.scorers import PROMPT, ClassifierTextScorer, ImageTextScorer, PerceptionError
from biovln_ms.render.goal_views import GoalViewRenderer, goal_views, showcase_scenes
from biovln_ms.render.sapien_utils import vulkan_device_label
from biovln_ms.task_config import NavTaskConfig

OFFSETS = (0.0, -15.0, 15.0)
PRESETS = ("fast", "quality")
TOP_K = (1, 3)


@dataclass(frozen=True)
class Scored:
    """One render and its scores: ``scores[j]`` is its similarity to category ``j``'s prompt."""

    category: str
    lighting: str
    offset: float
    rgb: np.ndarray
    scores: np.ndarray

    def rank(self, categories: list[str]) -> int:
        """1-based rank of the true category's prompt (ties count against it)."""
        truth = self.scores[categories.index(self.category)]
        return 1 + int(np.sum(np.delete(self.scores, categories.index(self.category)) >= truth))


class FrameCachedScorer(ClassifierTextScorer):
    """The offline scorer, its ImageNet probabilities computed once per frame for all prompts (the scores
    are ``ClassifierTextScorer``'s; its network is the cost of a call)."""

    _last: tuple[np.ndarray, np.ndarray] | None = None

    def class_probabilities(self, rgb: np.ndarray) -> np.ndarray:
        if self._last is None or self._last[0] is not rgb:
            self._last = (rgb, super().class_probabilities(rgb))
        return self._last[1]


class DetectorRecognizer:
    """The trained detector as a recogniser: category j's score is the share of the frame's central window
    (the middle half of its width and height, where the views look) covered by j's instances, each pixel
    weighted by its instance's score; a view with no instance in the window scores 0 everywhere."""

    def __init__(self, detector: TrainedDetector, categories: list[str]) -> None:
        self.segmenter = detector.segmenter
        self.categories = categories
        self.name = f"trained detector ({self.segmenter.path.name}, min score {self.segmenter.min_score})"

    def scores(self, rgb: np.ndarray) -> np.ndarray:
        h, w = rgb.shape[:2]
        window = (slice(h // 4, h - h // 4), slice(w // 4, w - w // 4))
        area = (h - 2 * (h // 4)) * (w - 2 * (w // 4))
        out = np.zeros(len(self.categories))
        for inst in self.segmenter.instances(rgb):
            out[self.categories.index(inst.category)] += inst.score * inst.mask[window].sum() / area
        return out


def score_all(scorer, rgb: np.ndarray, prompts: list[str]) -> np.ndarray:
    """Similarity of one frame to each prompt (target names, in category order); a
    :class:`DetectorRecognizer` scores the categories directly."""
    if isinstance(scorer, DetectorRecognizer):
        return scorer.scores(rgb)
    return np.array([scorer.score(rgb, p) for p in prompts], float)


def render_and_score(
    scorer: ImageTextScorer,
    categories: list[str],
    prompts: list[str],
    presets: tuple[str, ...] = PRESETS,
    width: int = 640,
    height: int = 480,
    hfov_deg: float = 79.0,
) -> list[Scored]:
    """Every category's Zone-3 views under each preset, scored against every category's prompt."""
    out = []
    for spec, objects in showcase_scenes(categories):
        for lighting in presets:
            renderer = GoalViewRenderer(spec, lighting, width=width, height=height, hfov_deg=hfov_deg)
            for o in objects:
                for offset, eye in zip(OFFSETS, goal_views(o, OFFSETS)):
                    rgb, _ = renderer.render(o, eye)
                    out.append(Scored(o.category, lighting, offset, rgb, score_all(scorer, rgb, prompts)))
    return out


def best_guess(scores: np.ndarray, categories: list[str]) -> str:
    """The best-scoring category, or "—" when every category scores the same (nothing told apart)."""
    return "—" if np.ptp(scores) == 0 else categories[int(np.argmax(scores))]


def top_k(results: list[Scored], categories: list[str], k: int) -> float:
    """Fraction of ``results`` whose true category ranks within the top ``k``."""
    return float(np.mean([r.rank(categories) <= k for r in results])) if results else float("nan")


def contact_sheet(results: list[Scored], categories: list[str], path: Path, thumb: int = 200) -> None:
    """One row per category, its views under each preset left to right, each captioned with the preset,
    the true category's rank and the best-scoring category (a web figure: 256 colours)."""
    from PIL import Image, ImageDraw

    from biovln_ms.assetgen.textures import font
    from biovln_ms.io_utils import atomic_write_bytes

    rows = [c for c in categories if any(r.category == c for r in results)]
    cols = max(sum(r.category == c for r in results) for c in rows)
    th = thumb * 3 // 4
    cap = 34
    sheet = Image.new("RGB", (cols * thumb, len(rows) * (th + cap)), (255, 255, 255))
    draw = ImageDraw.Draw(sheet)
    small = font(12)
    for i, c in enumerate(rows):
        for j, r in enumerate([r for r in results if r.category == c]):
            x, y = j * thumb, i * (th + cap)
            sheet.paste(Image.fromarray(r.rgb).resize((thumb, th), Image.BILINEAR), (x, y))
            best = best_guess(r.scores, categories)
            rank = r.rank(categories)
            colour = (0, 120, 40) if rank == 1 else (170, 110, 0) if rank <= 3 else (180, 20, 20)
            draw.text(
                (x + 3, y + th + 2), f"{c} {r.lighting} {r.offset:+.0f}°", fill=(20, 20, 20), font=small
            )
            draw.text((x + 3, y + th + 17), f"rank {rank}; best: {best}", fill=colour, font=small)
    import io

    buf = io.BytesIO()
    sheet.quantize(colors=256, method=Image.Quantize.MEDIANCUT).save(buf, format="PNG", optimize=True)
    path.parent.mkdir(parents=True, exist_ok=True)
    atomic_write_bytes(path, buf.getvalue())
    print(f"wrote {path}")


def face_colours() -> dict[str, int]:
    """Each category's fewest distinct colours at its Zone-3 views (``instrument_colours.json``, lighting
    quality), the paper's Table 8 column; empty when that table is absent."""
    path = docs_data_dir() / "benchmarks" / "instrument_colours.json"
    if not path.is_file():
        return {}
    table = load_table(path)
    col = table["columns"].index("min")
    return {row[0]: row[col] for row in table["rows"]}


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    which = ap.add_mutually_exclusive_group()
    which.add_argument("--clip", type=Path, metavar="DIR", help="a CLIP model saved with save_pretrained")
    which.add_argument("--detector", metavar="SPEC", help="'trained' (the shipped weights) or 'trained:FILE'")
    ap.add_argument(
        "--data-out", type=Path, help="the table (default: docs/data/benchmarks/recognition*.json)"
    )
    ap.add_argument(
        "--sheet", type=Path, help="the contact sheet (default: docs/images/recognition_sheet*.png)"
    )
    args = ap.parse_args(argv)
    from biovln_ms.perception.scorers import CLIPScorer

    catalog = load_catalog()
    categories = catalog.goal_categories()
    try:
        detector = make_detector(args.detector) if args.detector else None  # the spec grammar's one home
    except PerceptionError as e:
        ap.error(str(e))
    if args.detector and not isinstance(detector, TrainedDetector):
        ap.error(f"--detector {args.detector}: use 'trained' or 'trained:FILE'")
    scorer = (
        CLIPScorer(args.clip)
        if args.clip
        else DetectorRecognizer(detector, categories)
        if detector
        else FrameCachedScorer()
    )
    suffix = "_clip" if args.clip else "_detector" if args.detector else ""
    data_out = args.data_out or docs_data_dir() / "benchmarks" / f"recognition{suffix}.json"
    sheet = args.sheet or docs_data_dir().parent / "images" / f"recognition_sheet{suffix}.png"
    prompts = [catalog.get(c).display_name.lower() for c in categories]
    cfg = NavTaskConfig()
    results = render_and_score(
        scorer,
        categories,
        prompts,
        width=cfg.camera_width,
        height=cfg.camera_height,
        hfov_deg=cfg.camera_hfov_deg,
    )
    header = ["category", "prompt's target"]
    colours = face_colours() if args.detector else {}
    if colours:
        header.append("colours at the face (min)")
    for p in PRESETS:
        header += [f"{p}: top-1", f"{p}: top-3", f"{p}: best guess"]
    rows = []
    for c, prompt in zip(categories, prompts):
        row: list = [c, prompt] + ([colours.get(c)] if colours else [])
        for p in PRESETS:
            mine = [r for r in results if r.category == c and r.lighting == p]
            guesses = [best_guess(r.scores, categories) for r in mine]
            order = [*categories, "—"]
            common = max(set(guesses), key=lambda g: (guesses.count(g), -order.index(g)))
            row += [f"{sum(r.rank(categories) <= 1 for r in mine)}/{len(mine)}"]
            row += [f"{sum(r.rank(categories) <= 3 for r in mine)}/{len(mine)}", common]
        rows.append(row)
        print("  ".join(map(str, row)))
    total: list = ["all", f"{len(categories)} prompts"] + ([""] if colours else [])
    for p in PRESETS:
        mine = [r for r in results if r.lighting == p]
        total += [
            f"{100 * top_k(mine, categories, 1):.0f} %",
            f"{100 * top_k(mine, categories, 3):.0f} %",
            "",
        ]
    rows.append(total)
    print("  ".join(map(str, total)))
    contact_sheet(results, categories, sheet)
    notes = [
        (
            f"Scorer {scorer.name}; each view scored for all {len(categories)} categories"
            if args.detector
            else f"Scorer {scorer.name}; prompt '{PROMPT}' with each category's catalog display name; each "
            f"view scored against all {len(categories)} prompts"
        )
        + ", top-k: its own category among the k best. Views: "
        "the Eq. 1 goal and the goal turned ±15° about the object, the head camera's frame "
        f"({cfg.camera_width}×{cfg.camera_height}, 0.88 m high, looking at the object's centre); "
        f"scenes {', '.join(s.name for s, _ in showcase_scenes(categories))}; chance: top-1 "
        f"{100 / len(categories):.0f} %, top-3 {300 / len(categories):.0f} %.",
        "`fast` is the lighting of every released result (flat, no shadows); `quality` has shadowed ceiling "
        "fixtures (both with the PBR textures and per-instance looks).",
    ]
    if args.detector:
        notes.append(
            "The detector was trained on this project's renders of the train split's scenes (other scenes "
            "than these views'); a view counts at top-1 when the true category covers the most of the "
            "frame's central window, confidence-weighted; no instance there ranks every category last."
        )
    elif not args.clip:
        notes.append(
            "The offline scorer knows only ImageNet-1k's classes, projected onto each prompt by sentence "
            "similarity: it has 'refrigerator', 'trash can', 'filing cabinet', 'medicine cabinet', 'desk', "
            "'dining table', 'microwave oven', 'dishwasher', 'bathtub' and 'salt shaker', but no centrifuge, "
            "incubator, autoclave, freezer, fume hood, thermal cycler, pipette or even microscope, so this "
            "measures what a weak zero-shot scorer can read from the renders, not what a VLM could."
        )
    write_table(
        data_out,
        f"Recognition of each goal category from its Zone-3 views, {scorer.name}, before (fast) / after "
        "(quality)",
        header,
        rows,
        notes=notes,
        render_device=vulkan_device_label(),
    )


if __name__ == "__main__":
    main()
