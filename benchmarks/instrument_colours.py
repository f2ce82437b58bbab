"""Distinct colours of every goal category seen from its Zone-3 goal (paper Table 8).

The paper found GPT-4o recognised only the instrument with a rich surface (the biosafety cabinet,
12.6k-14.9k distinct colours), none of the near-uniform ones. For each goal category, its first instance
in the scenes of :func:`~biovln_ms.render.goal_views.showcase_scenes` (``two_room`` seed 0 for the paper's
ten categories, ``molecular_biology`` scenes for the seven molecular-biology ones) is seen by a head camera
like the env's (640x480, the task's 79 degree field of view, ManiSkill's "minimal" shader with 8-bit
colour, 0.88 m high) from three eyes: the Eq. 1 goal g = c + f (d + delta), and g turned by -15 and +15
degrees about the object's centre (all within the success radius), each looking at the object's centre,
under the lighting preset ``quality``. The count is of distinct RGB values inside the object's
segmentation mask.

    python benchmarks/instrument_colours.py [--lighting quality] [--before DIR] [--images DIR]
                                            [--only CAT ...]

``--before DIR`` renders the same views with the GLBs in DIR as shipped (no per-instance variants), for a
before/after table; the assets of an earlier commit come out of git with
``git archive COMMIT assets | tar -x -C /tmp/before`` (then ``--before /tmp/before/assets --before-name
"commit COMMIT"``). ``--images`` saves every view as PNG; ``--only`` measures a few categories (the table
is then not written). The table goes to ``docs/data/benchmarks/instrument_colours.json`` (``--data-out``),
which the docs' benchmarks page renders.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from biovln_ms.catalog import load_catalog
from biovln_ms.measured import docs_data_dir, write_table
from biovln_ms.render.goal_views import GoalViewRenderer, distinct_colours, goal_views, showcase_scenes
from biovln_ms.render.sapien_utils import vulkan_device_label
from biovln_ms.scene.spec import ObjectSpec
from biovln_ms.task_config import NavTaskConfig

OFFSETS = (0.0, -15.0, 15.0)
TARGET = 10_000


def measure(
    renderer: GoalViewRenderer, objects: list[ObjectSpec], images: Path | None, tag: str
) -> dict[str, tuple[list, list]]:
    """Per category: (distinct colours, mask pixels) of each view."""
    out = {}
    for o in objects:
        counts, pixels = [], []
        for k, eye in enumerate(goal_views(o, OFFSETS)):
            rgb, mask = renderer.render(o, eye)
            counts.append(distinct_colours(rgb, mask))
            pixels.append(int(mask.sum()))
            if images is not None:
                from PIL import Image

                images.mkdir(parents=True, exist_ok=True)
                Image.fromarray(rgb).save(images / f"{tag}_{o.category}_{OFFSETS[k]:+.0f}.png")
        out[o.category] = (counts, pixels)
    return out


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--lighting", default="quality")
    ap.add_argument("--before", type=Path, help="a directory of earlier GLBs to compare with")
    ap.add_argument("--before-name", help="what --before holds, for the table's note (e.g. 'commit 570a69c')")
    ap.add_argument("--images", type=Path, help="save each view here")
    ap.add_argument(
        "--data-out", type=Path, default=docs_data_dir() / "benchmarks" / "instrument_colours.json"
    )
    ap.add_argument("--only", nargs="+", metavar="CAT", help="measure these categories only (no table)")
    args = ap.parse_args(argv)
    cfg = NavTaskConfig()
    categories = load_catalog().goal_categories()
    if args.only:
        unknown = sorted(set(args.only) - set(categories))
        if unknown:
            ap.error(f"--only: {', '.join(unknown)} not a goal category (one of: {', '.join(categories)})")
        categories = [c for c in categories if c in args.only]
    kw = dict(width=cfg.camera_width, height=cfg.camera_height, hfov_deg=cfg.camera_hfov_deg)
    after: dict[str, tuple[list, list]] = {}
    before: dict[str, tuple[list, list]] | None = None if args.before is None else {}
    objects, names = [], []
    for spec, objs in showcase_scenes(categories):
        objects += objs
        names.append(spec.name)
        after |= measure(GoalViewRenderer(spec, args.lighting, **kw), objs, args.images, "after")
        if before is not None:
            r = GoalViewRenderer(spec, args.lighting, asset_dir=args.before, variants=False, **kw)
            before |= measure(r, objs, args.images, "before")
    size = f"{cfg.camera_width}×{cfg.camera_height}"
    print(f"device: {vulkan_device_label()}; {', '.join(names)}, lighting {args.lighting}, {size}")
    header = [
        "category",
        "object",
        "mask px at g, -15°, +15°",
        "colours at g, -15°, +15°",
        "min",
        f"≥ {TARGET:,}",
    ]
    if before is not None:
        header[4:4] = ["before: min"]
    rows = []
    for o in objects:
        counts, pixels = after[o.category]
        row = [
            o.category,
            o.id,
            " / ".join(f"{p:,}" for p in pixels),
            " / ".join(f"{c:,}" for c in counts),
            min(counts),
            "yes" if min(counts) >= TARGET else "no",
        ]
        if before is not None:
            row[4:4] = [min(before[o.category][0]) if o.category in before else None]
        rows.append(row)
        print("  ".join(str(c) for c in row))
    notes = [
        f"Scenes {', '.join(names)}; eyes at the Eq. 1 goal and at it turned ±15° about the object's "
        f"centre, 0.88 m high, looking at the centre; lighting `{args.lighting}`; the head camera's "
        "'minimal' shader, 8-bit colour; each instance in its own variant (labels, paint, wear). Paper "
        "Table 8: the biosafety cabinet, the one instrument recognised, showed 12.6k-14.9k colours.",
    ]
    for o in objects:
        counts, pixels = after[o.category]
        if max(pixels) < TARGET:
            bounds = " × ".join(f"{d:g}" for d in load_catalog().get(o.category).dimensions)
            notes.append(
                f"{o.category}: a view's count cannot exceed its mask's pixels, and its masks hold "
                f"{' / '.join(f'{p:,}' for p in pixels)} px: fewer than {TARGET:,} from its goal, whatever "
                f"the look (its bounds: {bounds} m, Table 2)."
            )
    if args.only:
        return
    if before is not None:
        what = f" ({args.before_name})" if args.before_name else ""
        notes.append(f"Before: the GLBs in `{args.before}`{what}, as shipped (no per-instance variants).")
    write_table(
        args.data_out,
        f"Distinct colours of each goal category from its Zone-3 goal, {size}, lighting {args.lighting}",
        header,
        rows,
        notes=notes,
        render_device=vulkan_device_label(),
    )


if __name__ == "__main__":
    main()
