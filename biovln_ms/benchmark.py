"""The paper's datasets (Tables 3, 4, 12, 13), defined from seeds and generator options only, and the
default dataset built from them (a composition of the episode model and the LSAT import).

* ``full``: 39 ``single_room`` scenes with 35 / 30 / 40 episodes per scene for 2 / 3 / 4-5 active
  instruments (Table 13), and 8 ``two_room`` scenes x 38 episodes. Table 3's 1,363 single-room
  episodes cannot be made of whole scenes with those counts (it needs 5a + 10c = 193); the nearest
  consistent construction, 13 scenes of each kind, gives 1,365 (+ 304 = 1,669 episodes, 47 scenes).
  The 13 four-to-five-instrument scenes include the seven held-out scenes; the others are the first
  seeds from 0 up that have the needed number of active slots.
* ``train``: the scenes of ``full`` that are in no benchmark split (a view of ``full``'s files).
* Hard track (ours; the paper has none): ``hard_val`` / ``hard_test``, 160 episodes each over held-out
  seeds of ``suite``, ``open_plan`` and ``single_room`` (see ``HARD_SPLITS``); the goal is a category and
  any instance counts (ObjectNav's rule), half of each scene's episodes drawn for a geodesic over 6 m.
* Benchmark splits (Table 4, pairwise disjoint): ``ms_dev`` seeds 150-153 x 40, ``ms_val`` 154 x 50,
  ``ms_test`` 155-156 x 60 (all holding cabinet, centrifuge, refrigerator and waste bin, Table 12:
  the generator's ``required_categories`` option), ``two_room`` (seed 200, 50 cross-room episodes)
  and ``lsat_target`` (the designer-authored scene ``assets/scenes/lsat_target.glb`` through the LSAT
  import, 40 episodes cycling over its 8 goal categories: 5 each, as Table 6's 20 % steps imply).
"""

from __future__ import annotations

import os
from pathlib import Path

from biovln_ms.episodes.dataset import DatasetError, EpisodeDataset, SplitPlan, write_dataset
from biovln_ms.scene.generator import generate_scene

FOUR_CATEGORIES = ("cabinet", "centrifuge", "refrigerator", "waste_bin")
HELD_OUT = {"ms_dev": ((150, 151, 152, 153), 40), "ms_val": ((154,), 50), "ms_test": ((155, 156), 60)}
TWO_ROOM_SEEDS = tuple(range(200, 208))
#: the Hard track (ours, not the paper's): held-out seeds of the multi-room templates and single rooms with
#: two instances of a category; any instance counts; per scene (template, seed, episodes)
HARD_SPLITS = {
    "hard_val": (
        ("suite", 400, 30),
        ("suite", 401, 30),
        ("open_plan", 450, 30),
        ("open_plan", 451, 30),
        ("single_room", 500, 20),
        ("single_room", 501, 20),
    ),
    "hard_test": (
        ("suite", 402, 30),
        ("suite", 403, 30),
        ("open_plan", 452, 30),
        ("open_plan", 453, 30),
        ("single_room", 503, 20),
        ("single_room", 504, 20),
    ),
}
HARD_SHARE = 0.5  # of each scene's episodes drawn for a geodesic over 6 m
TWO_ROOM_BENCH = (200, 50)
LSAT_EPISODES = 40
EPISODES_BY_ACTIVE = {2: 35, 3: 30, 4: 40, 5: 40}
SCENES_PER_BUCKET = 13
PAPER_MS_DEV_DIFFICULTY = {"easy": 11.9, "medium": 28.1, "hard": 60.0}
PAPER_TOTALS = {"scenes": 47, "episodes": 1667, "single_room_episodes": 1363, "two_room_episodes": 304}


def lsat_target_scene():
    """The shipped designer-authored GLB, imported (markers: strategy 1; the rest: strategy 2)."""
    from biovln_ms.lsat.designer_scene import target_glb_path
    from biovln_ms.lsat.importer import import_glb

    return import_glb(target_glb_path(), name="lsat_target")[0]


def _bucket(n_active: int) -> str:
    return {2: "two", 3: "three"}.get(n_active, "four_five")


def paper_splits() -> list[SplitPlan]:
    held = {
        seed: generate_scene("single_room", seed, required_categories=FOUR_CATEGORIES)
        for seeds, _ in HELD_OUT.values()
        for seed in seeds
    }
    buckets: dict[str, list] = {"two": [], "three": [], "four_five": list(held.values())}
    seed = 0
    while any(len(v) < SCENES_PER_BUCKET for v in buckets.values()):
        spec = generate_scene("single_room", seed)
        b = buckets[_bucket(len(spec.instruments))]
        if len(b) < SCENES_PER_BUCKET:
            b.append(spec)
        seed += 1
    singles = sorted((s for b in buckets.values() for s in b), key=lambda s: s.seed)
    two_rooms = [generate_scene("two_room", s) for s in TWO_ROOM_SEEDS]
    full = SplitPlan(
        "full",
        [(s, EPISODES_BY_ACTIVE[len(s.instruments)], False) for s in singles]
        + [(s, 38, False) for s in two_rooms],
        description="all 47 scenes, Table 13 episode counts (Table 3)",
    )
    bench_names = {held[s].name for seeds, _ in HELD_OUT.values() for s in seeds}
    two_bench = next(s for s in two_rooms if s.seed == TWO_ROOM_BENCH[0])
    bench_names.add(two_bench.name)
    train = SplitPlan(
        "train",
        [t for t in full.scenes if t[0].name not in bench_names],
        view_of="full",
        description="scenes of 'full' in no benchmark split",
    )
    out = [full, train]
    for name, (seeds, n) in HELD_OUT.items():
        out.append(
            SplitPlan(
                name,
                [(held[s], n, False) for s in seeds],
                description=f"Table 4: seeds {list(seeds)}, {n} per scene",
            )
        )
    out.append(
        SplitPlan(
            "two_room", [(two_bench, TWO_ROOM_BENCH[1], True)], description="Table 4: cross-room episodes"
        )
    )
    for name, scenes in HARD_SPLITS.items():
        out.append(
            SplitPlan(
                name,
                [(generate_scene(t, seed), n, False) for t, seed, n in scenes],
                description="Hard track: suite / open_plan / single_room held-out seeds, any instance counts",
                hard_share=HARD_SHARE,
            )
        )
    out.append(
        SplitPlan(
            "lsat_target",
            [(lsat_target_scene(), LSAT_EPISODES, False)],
            description="Table 4: designer-authored scene (LSAT import), 40 episodes, 8 categories",
        )
    )
    return out


def default_dataset_dir() -> Path:
    """``$BIOVLN_DATA_DIR``, else ``~/.cache/biovln_ms/datasets/biovln``."""
    env = os.environ.get("BIOVLN_DATA_DIR")
    return Path(env) if env else Path.home() / ".cache" / "biovln_ms" / "datasets" / "biovln"


def ensure_default_dataset(echo=print) -> Path:
    """The default dataset, built on first use and rebuilt when stale (deterministic, ~4 s; nothing
    is downloaded)."""
    root = default_dataset_dir()
    stale = False
    if (root / "manifest.json").exists():
        try:
            EpisodeDataset(root, verify=False)
        except DatasetError:
            stale = True
    if stale or not (root / "manifest.json").exists():
        echo(f"[biovln-ms] building the benchmark dataset in {root} ({'stale' if stale else 'first use'})")
        write_dataset(root, paper_splits(), progress=False)
    return root


def dataset_root(root: str | Path | None) -> Path:
    """``root``, or the default dataset (built on first use)."""
    return Path(root) if root is not None else ensure_default_dataset()
