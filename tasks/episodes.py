"""The navigation env's episodes: which one each reset sub-env starts, and what the measures know of one
(its goals, success radius and geodesic, paper §3.2 and Eq. 1)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from biovln_ms.agents.robots.locomotion import swept_motion
from biovln_ms.episodes.schema import Episode
from biovln_ms.episodes.source import EPISODE_OPTIONS, EpisodeCursor, EpisodeSource
from biovln_ms.geometry.motion import SweptMotion
from biovln_ms.geometry.navigation import NavGeometry
from biovln_ms.metrics.measures import EpisodeContext
from biovln_ms.scene.rules import scene_navigation
from biovln_ms.scene.spec import SceneSpec
from biovln_ms.task_config import NavTaskConfig
from biovln_ms.tasks.config_checks import EnvConfigError

#: scenes an env keeps (their geometry and their episodes' measure contexts): a split's scenes recur as its
#: episodes cycle; beyond this many, the least recently used is built again when it comes back
SCENE_CACHE = 64


@dataclass(frozen=True)
class SceneGeometry:
    """A scene's spec, navigation geometry and swept-motion checks for one robot footprint, and the measure
    contexts of its episodes made so far (by episode index), kept and dropped with it."""

    spec: SceneSpec
    nav: NavGeometry
    motion: SweptMotion
    contexts: dict[int, EpisodeContext] = field(default_factory=dict)

    def context(self, k: int, make: Callable[[], EpisodeContext]) -> EpisodeContext:
        """Episode ``k``'s context, made on its first use."""
        if k not in self.contexts:
            self.contexts[k] = make()
        return self.contexts[k]


def scene_geometry(source: EpisodeSource, scene_id: str, radius: float) -> SceneGeometry:
    """Scene ``scene_id`` of ``source`` for a robot footprint of ``radius``."""
    spec = source.spec(scene_id)
    return SceneGeometry(spec, scene_navigation(spec), swept_motion(spec, radius))


def choose_episodes(
    cursor: EpisodeCursor, episodes: list[Episode], rows, seed, options: dict, partial: bool
) -> tuple[dict[int, int], list[Episode], bool]:
    """The episode index of each reset sub-env of ``rows`` (the cursor's, a ``seed`` positioning it once;
    ``options`` may name one), every sub-env's episode after the reset, and whether a scene changes. A
    partial reset of a batched env cannot rebuild a sub-env's scene: its next episode is in the scene it
    holds, and naming one elsewhere is refused."""
    in_scene = partial and not EPISODE_OPTIONS & set(options)
    chosen, cursor_seed = {}, seed
    for i in rows:
        if in_scene:
            chosen[i] = cursor.next_in_scene(episodes[i]["scene_id"])
        else:
            chosen[i], cursor_seed = cursor.select(cursor_seed, options), None
    after = [cursor.source.episodes[chosen[i]] if i in chosen else e for i, e in enumerate(episodes)]
    changed = [ep["scene_id"] for ep in after] != [ep["scene_id"] for ep in episodes]
    if changed and partial:
        raise EnvConfigError(
            "a partial reset cannot change a sub-env's scene on the GPU",
            field="env_idx",
            fix="reset all sub-envs (reconfigure), or keep each sub-env's episodes in its scene",
        )
    return chosen, after, changed


def episode_context(ep: Episode, spec: SceneSpec, nav: NavGeometry, cfg: NavTaskConfig) -> EpisodeContext:
    """An episode for the measures: every goal of the episode counts (one, or each instance of the category
    where any instance counts), with the geodesic to the nearest."""
    goals, distance_fns = [], []
    for g in ep["goals"]:
        target = spec.get(g["object_id"]).placed()
        if cfg.goal_mode == "centroid":
            goal = target.centroid_goal()
            distance_fns.append(nav.distance_to(nav.snap(goal)))
        else:
            goal = np.asarray(g["position"][:2], float)
            distance_fns.append(nav.distance_to(goal))
        goals.append((goal, float(g["radius"]), target))
    geodesic = distance_fns[0] if len(distance_fns) == 1 else (lambda p: min(f(p) for f in distance_fns))
    start = np.asarray(ep["start_position"][:2], float)
    (goal, radius, target), *others = goals
    return EpisodeContext(
        goal=goal,
        success_radius=radius,
        target=target,
        instruments=[o.placed() for o in spec.instruments],
        geodesic=geodesic,
        start_geodesic=float(geodesic(start)),
        hfov=cfg.hfov,
        other_goals=tuple(others),
    )
