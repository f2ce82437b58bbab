"""The detector's labelled frames, model side (no simulator): what each frame shows, drawn from a seed, and
its annotations.

A frame is a head-camera view from a point along an episode's shortest path, at a robot's camera height
with jitter, looking along the path or at an instrument (:func:`plan_frame`). Frames come in groups of
:data:`FRAMES_PER_GROUP` that share one scene build: the scene (with or without lab dressing), the lighting
preset and every object's look are drawn per group, the viewpoint and the image-noise preset per frame.
Everything a frame shows is a function of ``(seed, frame index)`` only, whatever the order or the worker
that renders it.

Held out for testing (:data:`PARTS`): ``test_scenes`` frames show only scenes of the held-out scene set
(:func:`hold_out_scenes`), in training looks; ``test_looks`` frames show training scenes with every object
in a held-out look. A look (:class:`~biovln_ms.assetgen.variation.Variant`) is a key: the paint look
(tint and wear of the painted surfaces) is ``key % PAINTS`` and the live decals (asset tag, setpoints,
dates) are drawn from the key; the paint looks in :data:`HELD_OUT_PAINTS` never appear in ``train`` or
``test_scenes`` frames.
"""

from __future__ import annotations

import hashlib
import math
from dataclasses import dataclass, field

import numpy as np

from biovln_ms.episodes.bulk import usable_seeds
from biovln_ms.episodes.samplers import SceneSamplers, SingleGoalEpisodes
from biovln_ms.scene.generator import GenerationError, generate_scene
from biovln_ms.scene.templates import get_template, template_names
from biovln_ms.assetgen.variation import PAINTS, Variant, paint_look
from biovln_ms.catalog import load_catalog
from biovln_ms.errors import BioVLNError
from biovln_ms.geometry.navigation import UnreachableError
from biovln_ms.robot_specs import ROBOTS
from biovln_ms.scene.dressing import dress
from biovln_ms.scene.rules import scene_navigation
from biovln_ms.scene.spec import SceneSpec

FORMAT_VERSION = 1
#: the frames' parts: what a detector trains on, and the two held-out tests
PARTS = ("train", "test_scenes", "test_looks")
#: share of the groups in each part (a group's part is drawn from the seed)
PART_SHARES = (0.7, 0.15, 0.15)
#: share of the split's scenes held out for ``test_scenes``
HELD_OUT_SCENE_SHARE = 0.2
#: paint looks (of :data:`~biovln_ms.assetgen.variation.PAINTS`) only ``test_looks`` frames show
HELD_OUT_PAINTS = (3,)
TRAIN_PAINTS = tuple(p for p in range(PAINTS) if p not in HELD_OUT_PAINTS)
#: frames sharing one scene build (scene, dressing, lighting, looks)
FRAMES_PER_GROUP = 8
#: lighting presets (``biovln_ms.render.lighting.LIGHTING``) and their shares of the groups
LIGHTING_SHARES = {"fast": 0.6, "quality": 0.4}
#: image-noise presets (``biovln_ms.noise.PRESETS``) and their shares of the frames
NOISE_SHARES = {"ideal": 0.5, "realistic": 0.5}
#: share of the groups with lab dressing; a dressed group takes one of DRESSINGS dressings of its scene
DRESSED_SHARE = 0.5
DRESSINGS = 3
#: share of the frames that look at an instrument (the others look along the path)
FACING_SHARE = 0.6
#: camera height above the floor (m): the robots' head cameras (0.88, 1.061) with room either side
CAMERA_HEIGHT = (0.80, 1.15)
#: camera pitch (degrees, negative: down) and the heading jitter (degrees, standard deviation)
PITCH_DEG = (-12.0, 3.0)
FACING_JITTER_DEG = 12.0
ALONG_JITTER_DEG = 35.0
#: the streams of the seed's random numbers
_GROUP_STREAM, _FRAME_STREAM, _DRESS_STREAM = 0x67727570, 0x6672616D, 0x64726573


class FramesError(BioVLNError):
    """Bad input to the frame dataset's builder or reader."""


@dataclass(frozen=True)
class SceneSource:
    """A scene frames may show, with its episodes (whose shortest paths the viewpoints lie on)."""

    spec: SceneSpec
    episodes: tuple[dict, ...]

    @property
    def goal_categories(self) -> frozenset[str]:
        goals = set(load_catalog().goal_categories())
        return frozenset(o.category for o in self.spec.objects() if o.category in goals)


@dataclass(frozen=True)
class GroupDraw:
    """One scene build: the part, scene, dressing (0: none), lighting preset and each object's look key."""

    index: int
    part: str
    scene: str
    dressing: int
    lighting: str
    looks: dict[str, int] = field(hash=False)


@dataclass(frozen=True)
class FrameDraw:
    """One frame: its group, the camera's eye (x, y, z), heading and pitch (radians), the noise preset and
    its noise key, and the object it was turned towards ('' when it looks along the path)."""

    index: int
    group: GroupDraw
    eye: tuple[float, float, float]
    yaw: float
    pitch: float
    noise: str
    noise_key: int
    facing: str


def stable_hash(*parts: object) -> int:
    """A 63-bit hash of ``parts`` that is the same in every process (``hash()`` of a str is not)."""
    digest = hashlib.sha256("\x1f".join(map(str, parts)).encode()).digest()
    return int.from_bytes(digest[:8], "little") >> 1


def hold_out_scenes(sources: list[SceneSource], share: float = HELD_OUT_SCENE_SHARE) -> frozenset[str]:
    """The scenes kept for ``test_scenes``: about ``share`` of them, chosen in a fixed hash order so that
    every goal category held by two scenes or more is in both sets (a category of one scene stays in
    training). Deterministic: the same scenes give the same set."""
    order = sorted(sources, key=lambda s: stable_hash("held-out", s.spec.name))
    held: list[SceneSource] = []

    def keeps_training(s: SceneSource) -> bool:
        rest = [x for x in order if x is not s and x not in held]
        return all(any(c in x.goal_categories for x in rest) for c in s.goal_categories)

    holders = {c: [s for s in order if c in s.goal_categories] for s in order for c in s.goal_categories}
    for c in sorted(holders, key=lambda c: (len(holders[c]), c)):
        if len(holders[c]) < 2 or any(c in s.goal_categories for s in held):
            continue
        pick = next((s for s in holders[c] if keeps_training(s)), None)
        if pick is not None:
            held.append(pick)
    target = max(1, round(share * len(order))) if len(order) > 1 else 0
    for s in order:
        if len(held) >= target:
            break
        if s not in held and keeps_training(s):
            held.append(s)
    return frozenset(s.spec.name for s in held)


#: coverage scenes: the first seed tried, scenes per category the split lacks, episodes per scene
COVERAGE_FIRST_SEED = 5000
COVERAGE_SCENES_PER_CATEGORY = 3
COVERAGE_EPISODES = 20
COVERAGE_TRIES = 50  # seeds tried per category


def split_sources(dataset, split: str, held_out_seeds: dict[str, frozenset[int]]) -> list[SceneSource]:
    """The scenes of ``split`` of ``dataset`` (an :class:`~biovln_ms.episodes.dataset.EpisodeDataset`) with
    their episodes, then coverage scenes for the catalog's goal categories the split never shows: for each,
    :data:`COVERAGE_SCENES_PER_CATEGORY` scenes of the first template (by name) offering it, generated from
    seeds :data:`COVERAGE_FIRST_SEED` up without ``held_out_seeds`` (the benchmark scenes' seeds: no
    evaluation scene enters the frames), with :data:`COVERAGE_EPISODES` episodes each."""

    if split not in dataset.split_names():
        raise FramesError(
            f"the dataset has no split '{split}'",
            field="split",
            fix=f"use one of: {', '.join(dataset.split_names())}",
        )
    episodes: dict[str, list[dict]] = {}
    for ep in dataset.episodes(split):
        episodes.setdefault(ep["scene_id"], []).append(ep)
    out = [SceneSource(dataset.spec(name), tuple(eps)) for name, eps in episodes.items()]
    radius = dataset.agent_radius
    missing = [c for c in load_catalog().goal_categories() if not any(c in x.goal_categories for x in out)]
    samplers, seeds = SceneSamplers(), {}
    for cat in missing:
        templates = [t for t in template_names() if cat in get_template(t).categories()]
        if not templates:
            continue  # no template places it: the manifest's instance counts show the gap
        t = templates[0]
        seeds.setdefault(t, usable_seeds(t, COVERAGE_FIRST_SEED, held_out_seeds))
        for _ in range(COVERAGE_TRIES):
            if sum(cat in x.goal_categories for x in out) >= COVERAGE_SCENES_PER_CATEGORY:
                break
            seed = next(seeds[t])
            try:
                spec = generate_scene(t, seed, required_categories=[cat], robot_radius=radius)
            except GenerationError:
                continue
            eps = SingleGoalEpisodes().draw(samplers, spec, COVERAGE_EPISODES, seed)
            out.append(SceneSource(spec, tuple(eps)))
    return out


def look_key(rng: np.random.Generator, paints: tuple[int, ...]) -> int:
    """A look key whose paint look (``key % PAINTS``) is one of ``paints``."""
    return int(rng.integers(2**28)) * PAINTS + int(paints[int(rng.integers(len(paints)))])


def look_variant(key: int) -> Variant:
    """The look of ``key``: its paint look's tint and wear, its decals drawn from the key."""
    tint, wear = paint_look(key % PAINTS)
    return Variant(key=key, tint=tint, wear=wear)


def _choice(rng: np.random.Generator, shares: dict[str, float]) -> str:
    names = list(shares)
    p = np.asarray([shares[n] for n in names], float)
    return names[int(rng.choice(len(names), p=p / p.sum()))]


def draw_group(seed: int, g: int, sources: dict[str, SceneSource], held_out: frozenset[str]) -> GroupDraw:
    """Group ``g``'s scene build. Its part first, then a goal category uniformly among those the part's
    scenes hold (so rare categories are seen as often as common ones), then a scene holding it."""
    rng = np.random.default_rng([seed, _GROUP_STREAM, g])
    part = PARTS[int(rng.choice(len(PARTS), p=PART_SHARES))]
    names = sorted(n for n in sources if (n in held_out) == (part == "test_scenes"))
    if not names:
        raise FramesError(
            f"no scene for the '{part}' frames", field="scenes", fix="give a split with at least two scenes"
        )
    cats = sorted(set().union(*(sources[n].goal_categories for n in names)))
    cat = cats[int(rng.integers(len(cats)))]
    holders = [n for n in names if cat in sources[n].goal_categories]
    scene = holders[int(rng.integers(len(holders)))]
    dressing = int(rng.integers(1, DRESSINGS + 1)) if rng.random() < DRESSED_SHARE else 0
    lighting = _choice(rng, LIGHTING_SHARES)
    paints = HELD_OUT_PAINTS if part == "test_looks" else TRAIN_PAINTS
    spec = dressed_spec(sources[scene].spec, dressing)
    looks = {o.id: look_key(rng, paints) for o in spec.objects()}
    return GroupDraw(g, part, scene, dressing, lighting, looks)


#: per process: (id of a scene spec, dressing) -> (the spec, kept alive, its dressed spec, its navigation)
_SCENES: dict[tuple[int, int], tuple[SceneSpec, SceneSpec, object]] = {}
_SCENES_KEPT = 16


def _scene(spec: SceneSpec, dressing: int) -> tuple[SceneSpec, object]:
    """The dressed spec and its navigation geometry, made once per process (the last few kept)."""
    key = (id(spec), dressing)
    if key not in _SCENES or _SCENES[key][0] is not spec:
        if len(_SCENES) >= _SCENES_KEPT:
            _SCENES.pop(next(iter(_SCENES)))
        dressed = _dress(spec, dressing)
        _SCENES[key] = (spec, dressed, scene_navigation(dressed))
    return _SCENES[key][1], _SCENES[key][2]


def dressed_spec(spec: SceneSpec, dressing: int) -> SceneSpec:
    """``spec`` with its lab dressing number ``dressing`` (0: the spec itself), drawn from the scene's name
    and the number (:func:`biovln_ms.scene.dressing.dress`); the name stays the scene's."""
    return _scene(spec, dressing)[0]


def _dress(spec: SceneSpec, dressing: int) -> SceneSpec:
    if dressing == 0:
        return spec
    rng = np.random.default_rng([stable_hash(spec.name), _DRESS_STREAM, dressing])
    pieces = dress(spec, load_catalog(), rng, spec.robot_radius)
    data = spec.model_dump(mode="json")
    data["dressing"] = [*data.get("dressing", []), *(o.model_dump(mode="json") for o in pieces)]
    return SceneSpec.model_validate(data)


def _along(path: np.ndarray, t: float) -> tuple[np.ndarray, np.ndarray]:
    """The point at arc-length fraction ``t`` of ``path`` (k, 2) and the unit direction there."""
    seg = np.diff(path, axis=0)
    length = np.linalg.norm(seg, axis=1)
    if len(seg) == 0 or length.sum() < 1e-9:
        return path[0], np.array([1.0, 0.0])
    s = t * length.sum()
    k = int(np.searchsorted(np.cumsum(length), s, side="right").clip(0, len(seg) - 1))
    before = length[:k].sum()
    u = seg[k] / max(length[k], 1e-9)
    return path[k] + u * min(s - before, length[k]), u


def plan_frame(seed: int, i: int, group: GroupDraw, sources: dict[str, SceneSource]) -> FrameDraw:
    """Frame ``i`` of ``group``: a point on the shortest path of one of the scene's episodes (computed in the
    dressed scene, so the camera never stands inside a piece of dressing), the camera's height and pitch
    jittered; it faces a goal-category object (:data:`FACING_SHARE`, preferring the episode's target) or
    looks along the path. The noise preset is drawn per frame."""
    rng = np.random.default_rng([seed, _FRAME_STREAM, i])
    src = sources[group.scene]
    spec, nav = _scene(src.spec, group.dressing)
    ep = src.episodes[int(rng.integers(len(src.episodes)))]
    start = nav.snap(np.asarray(ep["start_position"][:2], float))
    goal = nav.snap(np.asarray(ep["goals"][0]["position"][:2], float), nav.island_of(start))
    try:
        path = nav.shortest_path(start, goal)
    except UnreachableError:  # the dressing cut the start off the goal's island: stay at the start
        path = start[None, :]
    xy, direction = _along(path, float(rng.random()))
    goals = set(load_catalog().goal_categories())
    facing = ""
    if rng.random() < FACING_SHARE:
        targets = [o for o in spec.objects() if o.category in goals]
        mine = [o for o in targets if o.id == ep["object_id"]]
        obj = mine[0] if mine and rng.random() < 0.5 else targets[int(rng.integers(len(targets)))]
        facing = obj.id
        d = np.asarray(obj.position[:2], float) - xy
        yaw = math.atan2(d[1], d[0]) + math.radians(rng.normal(0.0, FACING_JITTER_DEG))
    else:
        yaw = math.atan2(direction[1], direction[0]) + math.radians(rng.normal(0.0, ALONG_JITTER_DEG))
    z = float(rng.uniform(*CAMERA_HEIGHT))
    pitch = math.radians(float(rng.uniform(*PITCH_DEG)))
    noise = _choice(rng, NOISE_SHARES)
    yaw = math.atan2(math.sin(yaw), math.cos(yaw))
    eye = (round(float(xy[0]), 6), round(float(xy[1]), 6), round(z, 6))
    return FrameDraw(i, group, eye, round(yaw, 6), round(pitch, 6), noise, int(rng.integers(2**31)), facing)


def camera_heights() -> dict[str, float]:
    """The robots' head-camera heights (m), which :data:`CAMERA_HEIGHT` spans."""
    return {r.uid: r.camera_height for r in ROBOTS.values()}


# --- annotations -------------------------------------------------------------------------------------
def instance_annotations(instances: np.ndarray, categories: dict[int, int]) -> list[dict]:
    """COCO annotations of an instance-id image (H, W; 0: no goal-category object): per id, its category
    (``categories``: id -> COCO category id), the box ``[x, y, w, h]`` of its pixels (pixel edges, so a
    single pixel is 1 x 1), its area in pixels and its mask as COCO's compressed RLE (pycocotools)."""
    from pycocotools import mask as rle

    out = []
    for k in np.unique(instances):
        if k == 0:
            continue
        m = instances == k
        ys, xs = np.nonzero(m)
        encoded = rle.encode(np.asfortranarray(m.astype(np.uint8)))
        out.append(
            {
                "instance": int(k),
                "category_id": categories[int(k)],
                "bbox": [
                    int(xs.min()),
                    int(ys.min()),
                    int(xs.max() - xs.min() + 1),
                    int(ys.max() - ys.min() + 1),
                ],
                "area": int(m.sum()),
                "segmentation": {"size": list(encoded["size"]), "counts": encoded["counts"].decode("ascii")},
                "iscrowd": 0,
            }
        )
    return out


def decode_mask(segmentation: dict) -> np.ndarray:
    """The boolean mask of an annotation's RLE ``segmentation``."""
    from pycocotools import mask as rle

    return rle.decode(
        {"size": segmentation["size"], "counts": segmentation["counts"].encode("ascii")}
    ).astype(bool)


def coco_categories() -> list[dict]:
    """COCO's category list: the catalog's goal categories, ids from 1 in catalog order."""
    return [{"id": k + 1, "name": c} for k, c in enumerate(load_catalog().goal_categories())]
