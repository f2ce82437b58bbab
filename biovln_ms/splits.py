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
  ``hard_dressed_test``: ``hard_test``'s scenes with the generator's lab dressing.
* Benchmark splits (Table 4, pairwise disjoint): ``ms_dev`` seeds 150-153 x 40, ``ms_val`` 154 x 50,
  ``ms_test`` 155-156 x 60 (all holding cabinet, centrifuge, refrigerator and waste bin, Table 12:
  the generator's ``required_categories`` option), ``two_room`` (seed 200, 50 cross-room episodes)
  and ``lsat_target`` (the designer-authored scene ``assets/scenes/lsat_target.glb`` through the LSAT
  import, 40 episodes cycling over its 8 goal categories: 5 each, as Table 6's 20 % steps imply).
* Protocol splits (ours): ``protocol_train`` / ``protocol_val`` / ``protocol_test``, lab protocols
  as multi-goal episodes (``biovln_ms.protocols.episodes``) in scenes of all four templates, their seeds
  disjoint from every other split's (see ``PROTOCOL_SPLITS``).
* Busy splits (ours): ``busy_val`` / ``busy_test``, single-goal episodes in held-out scenes of the four
  paper templates, each episode with its own crowd of 1-4 technicians (``biovln_ms.people.episodes``: count,
  crowd seed, and how long its goal's face is occupied), at least a third of them with the goal's face
  occupied for part of the episode (see ``BUSY_SPLITS``).
* Molecular-biology splits (ours): ``molbio_val`` / ``molbio_test``, scenes of the
  ``molecular_biology`` template, the only one offering the catalog's seven molecular-biology categories,
  on seeds no other split uses (see ``MOLBIO_SPLITS``); any instance of the category counts. The paper's
  splits never hold them.

Every split is built for one robot (``biovln_ms.robot_specs``): its scenes are generated, and their layout
rules checked, for that robot's footprint radius. The default robot's dataset is the benchmark's; another
robot's default dataset is a sibling folder (``default_dataset_dir``).
"""

from __future__ import annotations

from collections import defaultdict

import contextlib
import os
from pathlib import Path

from biovln_ms.episodes.dataset import DatasetError, EpisodeDataset
from biovln_ms.episodes.samplers import AnyInstanceEpisodes, ProtocolEpisodes, SingleGoalEpisodes
from biovln_ms.episodes.writer import SplitPlan, write_dataset
from biovln_ms.lsat.designer_scene import target_glb_path
from biovln_ms.lsat.importer import import_glb
from biovln_ms.paths import default_cache_root
from biovln_ms.people.crowd import step_seconds
from biovln_ms.people.episodes import BusyEpisodes
from biovln_ms.protocols.episodes import hosted_protocols
from biovln_ms.protocols.library import ProtocolLibrary, load_protocols
from biovln_ms.robot_specs import DEFAULT_ROBOT, robot_spec
from biovln_ms.scene.generator import generate_scene
from biovln_ms.scene.spec import SceneSpec
from biovln_ms.variants import BENCHMARK_ENV, BUSY_PEOPLE, VARIANTS

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
#: the Hard track with lab dressing (ours): a split's scenes, same templates, seeds and instrument
#: layouts, with the generator's lab dressing (``<scene>_dressed``): the two differ only in the clutter
HARD_DRESSED = {"hard_dressed_test": "hard_test"}
TWO_ROOM_BENCH = (200, 50)
LSAT_EPISODES = 40
EPISODES_BY_ACTIVE = {2: 35, 3: 30, 4: 40, 5: 40}
SCENES_PER_BUCKET = 13
PAPER_MS_DEV_DIFFICULTY = {"easy": 11.9, "medium": 28.1, "hard": 60.0}
PAPER_TOTALS = {"scenes": 47, "episodes": 1667, "single_room_episodes": 1363, "two_room_episodes": 304}
#: Protocol splits (ours): per split, the first seed and the scenes per template. From the first seed up, a
#: split takes the first scenes of each template that host at least PROTOCOL_MIN_HOSTED shipped protocols
#: (scanning at most PROTOCOL_SEED_SCAN seeds: 600-649, 700-749, 800-849, no seed of another split); single
#: rooms are generated with FOUR_CATEGORIES (their slots hold only those, which two protocols visit).
PROTOCOL_SPLITS = {"protocol_train": (600, 3), "protocol_val": (700, 2), "protocol_test": (800, 2)}
PROTOCOL_TEMPLATES = ("single_room", "two_room", "suite", "open_plan")
PROTOCOL_EPISODES_PER_SCENE = 20
PROTOCOL_MIN_HOSTED = 2
PROTOCOL_SEED_SCAN = 50
#: Molecular-biology splits (ours): per split, the first seed and the number of scenes (seeds 900-903 and
#: 950-955). Scene i of a split is generated holding MOLBIO_WALL[i % 3] and MOLBIO_TABLE[i % 4]
#: (``required_categories``), so each split holds all seven new categories; the rest of the layout is the
#: seed's. Episodes name a category and any instance counts (as on the Hard track); no hard share.
MOLBIO_TEMPLATE = "molecular_biology"
MOLBIO_WALL = ("fume_hood", "ultra_low_freezer", "autoclave")
MOLBIO_TABLE = ("thermal_cycler", "microscope", "water_bath", "shaker")
MOLBIO_SPLITS = {"molbio_val": (900, 4), "molbio_test": (950, 6)}
MOLBIO_EPISODES = 30
#: Busy splits (ours): per split, (template, seed) of its scenes (seeds no other split uses), BUSY_EPISODES
#: single-goal episodes each, a crowd of 1 to BUSY_MAX_PEOPLE per episode; single rooms hold FOUR_CATEGORIES
BUSY_SPLITS = {
    "busy_val": (("single_room", 1000), ("two_room", 1001), ("suite", 1002), ("open_plan", 1003)),
    "busy_test": (("single_room", 1050), ("two_room", 1051), ("suite", 1052), ("open_plan", 1053)),
}
BUSY_EPISODES = 16
BUSY_MAX_PEOPLE = BUSY_PEOPLE  # the busy variants' figures
BUSY_OCCUPIED_EVERY = 3  # every third episode has its goal's face occupied for part of the episode


def lsat_target_scene(robot: str = DEFAULT_ROBOT):
    """The shipped designer-authored GLB, imported for ``robot`` (markers: strategy 1; the rest: 2)."""

    radius = robot_spec(robot, "robot").footprint_radius
    return import_glb(target_glb_path(), name="lsat_target", robot_radius=radius)[0]


def _bucket(n_active: int) -> str:
    return {2: "two", 3: "three"}.get(n_active, "four_five")


def paper_splits(robot: str = DEFAULT_ROBOT) -> list[SplitPlan]:
    """Every split of the paper's datasets (and the Hard track), its scenes generated for ``robot``."""
    r = robot_spec(robot, "robot").footprint_radius
    held = {
        seed: generate_scene("single_room", seed, required_categories=FOUR_CATEGORIES, robot_radius=r)
        for seeds, _ in HELD_OUT.values()
        for seed in seeds
    }
    buckets: dict[str, list] = {"two": [], "three": [], "four_five": list(held.values())}
    seed = 0
    while any(len(v) < SCENES_PER_BUCKET for v in buckets.values()):
        spec = generate_scene("single_room", seed, robot_radius=r)
        b = buckets[_bucket(len(spec.instruments))]
        if len(b) < SCENES_PER_BUCKET:
            b.append(spec)
        seed += 1
    singles = sorted((s for b in buckets.values() for s in b), key=lambda s: s.seed)
    two_rooms = [generate_scene("two_room", s, robot_radius=r) for s in TWO_ROOM_SEEDS]
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
                [(generate_scene(t, seed, robot_radius=r), n, False) for t, seed, n in scenes],
                description="Hard track: suite / open_plan / single_room held-out seeds, any instance counts",
                sampler=AnyInstanceEpisodes(HARD_SHARE),
            )
        )
    for name, base in HARD_DRESSED.items():
        out.append(
            SplitPlan(
                name,
                [
                    (generate_scene(t, seed, robot_radius=r, dressing=True), n, False)
                    for t, seed, n in HARD_SPLITS[base]
                ],
                description=f"Hard track: the scenes of {base} with lab dressing, any instance counts",
                sampler=AnyInstanceEpisodes(HARD_SHARE),
            )
        )
    out.append(
        SplitPlan(
            "lsat_target",
            [(lsat_target_scene(robot), LSAT_EPISODES, False)],
            description="Table 4: designer-authored scene (LSAT import), 40 episodes, 8 categories",
        )
    )
    return out + protocol_splits(robot) + molbio_splits(robot) + busy_splits(robot)


def protocol_scenes(
    template: str, first_seed: int, count: int, library: ProtocolLibrary, robot: str = DEFAULT_ROBOT
) -> list[SceneSpec]:
    """The first ``count`` scenes of ``template`` from ``first_seed`` up that host at least
    ``PROTOCOL_MIN_HOSTED`` protocols of ``library`` (a scene hosting fewer is skipped: the resample)."""
    r = robot_spec(robot, "robot").footprint_radius
    required = FOUR_CATEGORIES if template == "single_room" else ()
    found = []
    for seed in range(first_seed, first_seed + PROTOCOL_SEED_SCAN):
        spec = generate_scene(template, seed, required_categories=required, robot_radius=r)
        if len(hosted_protocols(spec, library)) >= PROTOCOL_MIN_HOSTED:
            found.append(spec)
            if len(found) == count:
                return found
    raise DatasetError(
        f"only {len(found)} of seeds {first_seed}-{first_seed + PROTOCOL_SEED_SCAN - 1} of '{template}' host "
        f"{PROTOCOL_MIN_HOSTED} protocols, {count} are needed",
        field="PROTOCOL_SPLITS",
        fix="lower the scene count or PROTOCOL_MIN_HOSTED, or scan more seeds",
    )


def protocol_splits(robot: str = DEFAULT_ROBOT) -> list[SplitPlan]:
    """The protocol splits of the shipped protocols (never the user's: the default dataset is the same
    everywhere), ``PROTOCOL_EPISODES_PER_SCENE`` episodes per scene."""
    library = load_protocols(env=False)
    out = []
    for name, (first_seed, count) in PROTOCOL_SPLITS.items():
        scenes = [
            (spec, PROTOCOL_EPISODES_PER_SCENE, False)
            for template in PROTOCOL_TEMPLATES
            for spec in protocol_scenes(template, first_seed, count, library, robot)
        ]
        out.append(
            SplitPlan(
                name,
                scenes,
                description=f"lab protocols, K = 2-5 ordered goals: {count} scenes per template from seed "
                f"{first_seed}",
                sampler=ProtocolEpisodes(library),
            )
        )
    return out


def molbio_splits(robot: str = DEFAULT_ROBOT) -> list[SplitPlan]:
    """The molecular-biology splits (``MOLBIO_SPLITS``), their scenes generated for ``robot``."""
    r = robot_spec(robot, "robot").footprint_radius
    out = []
    for name, (first_seed, count) in MOLBIO_SPLITS.items():
        scenes = [
            (
                generate_scene(
                    MOLBIO_TEMPLATE,
                    first_seed + i,
                    required_categories=(
                        MOLBIO_WALL[i % len(MOLBIO_WALL)],
                        MOLBIO_TABLE[i % len(MOLBIO_TABLE)],
                    ),
                    robot_radius=r,
                ),
                MOLBIO_EPISODES,
                False,
            )
            for i in range(count)
        ]
        out.append(
            SplitPlan(
                name,
                scenes,
                description=f"molecular-biology lab, new categories: seeds {first_seed}-"
                f"{first_seed + count - 1}, {MOLBIO_EPISODES} per scene, any instance counts",
                sampler=AnyInstanceEpisodes(hard_share=0.0),
            )
        )
    return out


def busy_step_seconds() -> float:
    """The time of an action step the busy splits' crowds walk in: the benchmark variant's."""
    cfg = VARIANTS[BENCHMARK_ENV]
    return step_seconds(cfg.forward_step, cfg.turn_deg)


def busy_splits(robot: str = DEFAULT_ROBOT) -> list[SplitPlan]:
    """The busy splits (``BUSY_SPLITS``): the benchmark variant's step limit and step time give each
    episode's occupied steps."""
    r, cfg = robot_spec(robot, "robot").footprint_radius, VARIANTS[BENCHMARK_ENV]
    sampler = BusyEpisodes(
        SingleGoalEpisodes(), BUSY_MAX_PEOPLE, cfg.max_episode_steps, busy_step_seconds(), BUSY_OCCUPIED_EVERY
    )
    out = []
    for name, scenes in BUSY_SPLITS.items():
        plan = [
            (
                generate_scene(
                    t, seed, required_categories=FOUR_CATEGORIES if t == "single_room" else (), robot_radius=r
                ),
                BUSY_EPISODES,
                False,
            )
            for t, seed in scenes
        ]
        out.append(
            SplitPlan(
                name,
                plan,
                description=f"people in the lab: {BUSY_EPISODES} episodes per scene of seeds "
                f"{[seed for _, seed in scenes]}, 1-{BUSY_MAX_PEOPLE} people each",
                sampler=sampler,
            )
        )
    return out


def paper_split_names() -> list[str]:
    """The names of :func:`paper_splits`' splits, in order, without generating a scene."""
    return [
        "full",
        "train",
        *HELD_OUT,
        "two_room",
        *HARD_SPLITS,
        *HARD_DRESSED,
        "lsat_target",
        *PROTOCOL_SPLITS,
        *MOLBIO_SPLITS,
        *BUSY_SPLITS,
    ]


def stale_paper_dataset(root: Path, robot: str = DEFAULT_ROBOT, same_splits: bool = True) -> str | None:
    """Why ``root`` is not an up-to-date build of the paper's datasets for ``robot`` (absent, incomplete,
    another format, generator version, catalog or robot; with ``same_splits``, another split set), or None
    when it is. The build is deterministic, so an up-to-date folder holds what a rebuild would write."""
    if not (root / "manifest.json").exists():
        return "first use"
    try:
        ds = EpisodeDataset(root, verify=False, robot=robot)
    except DatasetError:
        return "stale"
    if same_splits and sorted(ds.manifest["splits"]) != sorted(paper_split_names()):
        return "other splits"
    return None


def default_dataset_dir(robot: str = DEFAULT_ROBOT) -> Path:
    """``$BIOVLN_DATA_DIR``, else ``~/.cache/biovln_ms/datasets/biovln``; another robot's is the sibling
    ``<that name>-<robot>`` (``biovln-fetch``)."""
    env = os.environ.get("BIOVLN_DATA_DIR")
    root = Path(env) if env else default_cache_root() / "datasets" / "biovln"
    return root if robot == DEFAULT_ROBOT else root.with_name(f"{root.name}-{robot_spec(robot, 'robot').uid}")


def ensure_default_dataset(echo=print, robot: str = DEFAULT_ROBOT, progress: bool | None = None) -> Path:
    """``robot``'s default dataset, built on first use and rebuilt when stale (deterministic and
    local: nothing is downloaded). A build takes minutes, once per machine and robot, so it says so
    before it starts and then names each stage: generating the scenes, then sampling their episodes,
    with a progress bar and the time left when ``progress`` (default: when stderr is a terminal)."""
    root = default_dataset_dir(robot)
    root.parent.mkdir(parents=True, exist_ok=True)
    with _build_lock(root):  # concurrent first uses (eval workers, test workers) wait for one build
        return _ensure(root, echo, robot, progress)


@contextlib.contextmanager
def _build_lock(root: Path):
    """An exclusive ``flock`` on ``.<root>.lock`` beside ``root``, released however its holder ends."""
    import fcntl

    with open(root.parent / f".{root.name}.lock", "a") as f:
        fcntl.flock(f, fcntl.LOCK_EX)
        yield


def _ensure(root: Path, echo, robot: str, progress: bool | None) -> Path:
    import sys
    import time

    why = stale_paper_dataset(root, robot, same_splits=False)  # a user's $BIOVLN_DATA_DIR may hold others
    if why:
        t0 = time.perf_counter()
        echo(
            f"[biovln-ms] building the {robot} benchmark dataset in {root} ({why}; minutes, once per "
            "machine; BIOVLN_DATA_DIR moves it): generating its scenes"
        )
        plans = paper_splits(robot)
        scenes = {spec.name for plan in plans for spec, _, _ in plan.scenes}
        todo = sum(len(plan.scenes) for plan in plans if not plan.view_of)
        echo(
            f"[biovln-ms] scenes generated: {len(scenes)} in {time.perf_counter() - t0:.0f} s; sampling "
            f"their episodes, split by split ({todo} files)"
        )
        bar = sys.stderr.isatty() if progress is None else progress
        write_dataset(root, plans, progress=bar, robot=robot)
        echo(f"[biovln-ms] dataset built in {time.perf_counter() - t0:.0f} s")
    return root


def dataset_root(root: str | Path | None, robot: str = DEFAULT_ROBOT) -> Path:
    """``root``, or ``robot``'s default dataset (built on first use)."""
    return Path(root) if root is not None else ensure_default_dataset(robot=robot)


def held_out_seeds() -> dict[str, frozenset[int]]:
    """Template -> the seeds of the scenes of the paper's evaluation splits (all but ``full``, ``train`` and
    ``protocol_train``): MS DEV/VAL/TEST, the two-room benchmark scene, the Hard track (and its dressed
    scenes), every seed the protocol validation and test scans may take, the molecular-biology splits and the
    busy splits. A training split built by ``dataset build --template`` uses none of them (the ``held_out`` of
    :func:`biovln_ms.episodes.bulk.build_training_split`)."""
    seeds: dict[str, set[int]] = defaultdict(set)
    for held, _ in HELD_OUT.values():
        seeds["single_room"].update(held)
    seeds["two_room"].add(TWO_ROOM_BENCH[0])
    for rows in HARD_SPLITS.values():  # hard_dressed_test: hard_test's seeds
        for template, seed, _ in rows:
            seeds[template].add(seed)
    for name, (first, _) in PROTOCOL_SPLITS.items():
        if name != "protocol_train":
            for template in PROTOCOL_TEMPLATES:
                seeds[template].update(range(first, first + PROTOCOL_SEED_SCAN))
    for first, count in MOLBIO_SPLITS.values():
        seeds[MOLBIO_TEMPLATE].update(range(first, first + count))
    for rows in BUSY_SPLITS.values():
        for template, seed in rows:
            seeds[template].add(seed)
    return {t: frozenset(s) for t, s in seeds.items()}
