"""Where an env's episodes come from: a dataset split, or a scene generated on the fly and the episodes a
sampler (:mod:`biovln_ms.episodes.samplers`) draws in it. Either way they are
:class:`~biovln_ms.episodes.schema.Episode` objects."""

from __future__ import annotations

import os
import weakref
from pathlib import Path

import numpy as np

from biovln_ms.episodes.dataset import DatasetError, EpisodeDataset
from biovln_ms.episodes.samplers import Sampler, SceneSamplers, SingleGoalEpisodes
from biovln_ms.episodes.schema import Episode
from biovln_ms.robot_specs import DEFAULT_ROBOT, robot_spec
from biovln_ms.scene.generator import generate_scene
from biovln_ms.scene.spec import SceneSpec


class EpisodeSource:
    """A list of episodes and the scene specs they need."""

    episodes: list[Episode]

    def spec(self, scene_id: str) -> SceneSpec:
        raise NotImplementedError

    def __len__(self) -> int:
        return len(self.episodes)

    def by_scene(self) -> dict[str, list[int]]:
        """Each scene's episode indices, in source order."""
        scenes: dict[str, list[int]] = {}
        for i, ep in enumerate(self.episodes):
            scenes.setdefault(ep["scene_id"], []).append(i)
        return scenes

    def find(self, episode_id: str, scene_id: str | None = None) -> int:
        for i, e in enumerate(self.episodes):
            if e["episode_id"] == str(episode_id) and (scene_id is None or e["scene_id"] == scene_id):
                return i
        scenes = sorted({e["scene_id"] for e in self.episodes})
        raise DatasetError(
            f"no episode '{episode_id}'" + (f" in scene '{scene_id}'" if scene_id else ""),
            field="episode_id",
            fix=f"episode ids are '0'..; scenes: {', '.join(scenes)}; or pass options={{'episode_index': k}} "
            f"with 0 <= k < {len(self.episodes)}",
        )


#: 2**64 / φ, odd: Fibonacci hashing's multiplier (Knuth, TAOCP vol. 3, §6.4)
_GOLDEN_64 = 0x9E3779B97F4A7C15


def seed_position(seed: int, n: int) -> int:
    """Where ``reset(seed=...)`` starts in an order of ``n`` episodes: ``n · frac(seed / φ)``, computed
    exactly in 64-bit fixed point. Vector envs seed env ``i`` with ``seed + i`` (gymnasium's, SB3's); as
    ``seed mod n`` env ``i + 1`` would replay env ``i``'s episodes one step ahead, while golden-ratio steps
    start them far apart. Seed 0 is the first episode; every position is some seed's."""
    return (int(seed) * _GOLDEN_64 % 2**64) * n >> 64


#: how a seed places the cursor (:func:`seed_position`), as a training run's ``train.json`` records it
SEED_RULE = "golden"


#: the reset options that name an episode (``EpisodeCursor.select`` consumes them)
EPISODE_OPTIONS = frozenset({"episode_index", "episode_id"})


class EpisodeCursor:
    """Which episode a reset starts (Habitat's episode iterator): dataset order, or (``shuffle``) a fixed
    shuffle that keeps each scene's episodes together, so a scene is rebuilt once per pass, not per
    episode. ``visit`` > 0 plays the shuffle in passes: each pass takes the next ``visit`` episodes of every
    scene that has some left, in the shuffled scene order (a scene with more episodes than the others ends
    the order with its own)."""

    def __init__(self, source: EpisodeSource, shuffle: bool = False, visit: int = 0) -> None:
        self.source = source
        self.order = self._shuffled(visit) if shuffle else list(range(len(source)))
        self.position = -1
        self._scene_order: dict[str, list[int]] = {}  # scene -> its episodes, in this cursor's order
        self._scene_position: dict[str, int] = {}

    def _shuffled(self, visit: int) -> list[int]:
        rng = np.random.default_rng(0)
        by_scene = self.source.by_scene()
        scenes = sorted(by_scene)
        runs: list[list[int]] = []
        for k in rng.permutation(len(scenes)):
            episodes = by_scene[scenes[k]]
            runs.append([episodes[j] for j in rng.permutation(len(episodes))])
        if not visit:
            return [i for run in runs for i in run]
        longest = max(len(run) for run in runs)
        return [i for start in range(0, longest, visit) for run in runs for i in run[start : start + visit]]

    @property
    def first(self) -> int:
        return self.order[0]

    def select(self, seed, options: dict) -> int:
        """The episode index a reset starts: ``options["episode_index"]`` or ``["episode_id"]`` (with an
        optional ``["scene_id"]``), else the next in order; a ``seed`` jumps to position
        :func:`seed_position`, so the same seed gives the same episode and the
        same ones after it, and seeds ``s, s + 1, ...`` start far apart. Consumes those option keys."""
        if "episode_index" in options:
            k = options.pop("episode_index")
            if not (
                isinstance(k, (int, np.integer)) and not isinstance(k, bool) and 0 <= k < len(self.source)
            ):
                raise DatasetError(
                    f"episode_index {k!r} is out of range",
                    field="episode_index",
                    fix=f"use 0 <= episode_index < {len(self.source)}",
                )
            return int(k)
        if "episode_id" in options:
            return self.source.find(options.pop("episode_id"), options.pop("scene_id", None))
        if seed is not None:
            self.position = seed_position(int(np.ravel(seed)[0]), len(self.order))
        else:
            self.position = (self.position + 1) % len(self.order)
        return self.order[self.position]

    def next_in_scene(self, scene_id: str) -> int:
        """The next episode of ``scene_id`` in this cursor's order, cycling: a partial reset of a batched
        env keeps its sub-env's scene (ManiSkill rebuilds scenes only when all sub-envs reset)."""
        if scene_id not in self._scene_order:
            episodes = self.source.episodes
            self._scene_order[scene_id] = [i for i in self.order if episodes[i]["scene_id"] == scene_id]
        order = self._scene_order[scene_id]
        k = self._scene_position[scene_id] = (self._scene_position.get(scene_id, -1) + 1) % len(order)
        return order[k]


class DatasetEpisodes(EpisodeSource):
    """A split of a dataset built for ``robot`` (another robot's is refused)."""

    _signature: tuple | None = None  # the files as :meth:`shared` read them

    def __init__(self, split: str, root: str | Path, robot: str = DEFAULT_ROBOT) -> None:
        root = Path(root)
        self.dataset = EpisodeDataset(root, robot=robot)
        self.split = split
        self.episodes = list(self.dataset.episodes(split))
        if not self.episodes:
            raise DatasetError(f"split '{split}' of {root} has no episodes", field="split")

    def spec(self, scene_id: str) -> SceneSpec:
        return self.dataset.spec(scene_id)

    @classmethod
    def shared(cls, split: str, root: str | Path, robot: str = DEFAULT_ROBOT) -> DatasetEpisodes:
        """The split as this process read it for an env that still lives, while the manifest and every
        file it lists keep their inode, size and modification time; else read and verified afresh. The
        envs of one process then share one copy of the episodes and scene specs. When the process's first
        env is made from it, :func:`~biovln_ms.sim.maniskill_compat.freeze_live_objects` freezes that copy,
        so ManiSkill's full ``gc.collect()`` at each scene change does not walk a copy per env."""
        base = Path(root).resolve()
        key = (str(base), split, robot)
        held = _SHARED.get(key)
        if held is not None and held._signature == _file_signature(held.dataset, base):
            return held
        manifest = _stat(base / "manifest.json")
        source = cls(split, root, robot)
        signature = _file_signature(source.dataset, base)
        if signature[0] == manifest and None not in signature:  # nothing replaced or removed meanwhile
            source._signature = signature
            _SHARED[key] = source
        return source


#: sources read by :meth:`DatasetEpisodes.shared`, while something else holds them
_SHARED: weakref.WeakValueDictionary[tuple, DatasetEpisodes] = weakref.WeakValueDictionary()


def _stat(path: Path) -> tuple[int, int, int] | None:
    try:
        st = os.stat(path)
    except OSError:
        return None
    return st.st_ino, st.st_size, st.st_mtime_ns


def _file_signature(dataset: EpisodeDataset, base: Path) -> tuple:
    """The stat of the manifest and of every file it lists, under the dataset's resolved folder."""
    m = dataset.manifest
    rels = [info["file"] for info in m["scenes"].values()]
    rels += [info["file"] for split in m["splits"].values() for info in split["files"].values()]
    return (_stat(base / "manifest.json"), *(_stat(base / rel) for rel in rels))


class GeneratedEpisodes(EpisodeSource):
    """One scene generated from ``template``/``scene_seed`` for ``robot``'s footprint; ``n`` episodes drawn
    in it by ``sampler`` from ``scene_seed``."""

    def __init__(
        self,
        template: str = "single_room",
        scene_seed: int = 0,
        n: int = 100,
        required_categories: tuple[str, ...] = (),
        robot: str = DEFAULT_ROBOT,
        sampler: Sampler = SingleGoalEpisodes(),
    ) -> None:
        self._spec = generate_scene(
            template,
            scene_seed,
            required_categories=required_categories,
            robot_radius=robot_spec(robot).footprint_radius,
        )
        self.episodes = sampler.draw(SceneSamplers(), self._spec, n, scene_seed)

    def spec(self, scene_id: str) -> SceneSpec:
        return self._spec
