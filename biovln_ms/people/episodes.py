"""Episodes with their own crowd (the busy splits): each carries ``people`` — how many technicians, the crowd
seed the env resets them from, and how long its goal's face is occupied — so the episode replays with the
same crowd whatever the env's ``people=``.

How long the face is occupied is measured on the pure model (no simulator): the crowd walks the episode's
step limit with the robot standing at its start, and every step after which a person's body overlaps the
goal's Zone 3 counts (the rule of ``strict_success``). A moving robot makes people wait or step aside, so
in an env the occupied steps differ somewhat: the figure says which episodes put a person at the goal.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import shapely

from biovln_ms.episodes.generator import stable_seed
from biovln_ms.episodes.samplers import Sampler, SceneSamplers
from biovln_ms.episodes.schema import Episode
from biovln_ms.geometry.navigation import NavGeometry
from biovln_ms.people.body import overlaps_zone
from biovln_ms.people.crowd import Crowd, CrowdError, stations
from biovln_ms.scene.spec import SceneSpec

#: crowd seeds tried for an episode that should have its goal's face occupied, before the last is kept
OCCUPIED_ATTEMPTS = 8


def _crowd(spec: SceneSpec, nav: NavGeometry, ep: Episode, count: int, seed: int) -> tuple[Crowd, np.ndarray]:
    """``count`` people reset from ``seed`` for episode ``ep``, and the robot's start."""
    start = np.asarray(ep["start_position"][:2], float)
    crowd = Crowd(count)
    crowd.reset(nav, stations(spec, nav, start), start, nav.radius, seed, spec.name, count)
    return crowd, start


def occupied_steps(
    spec: SceneSpec, nav: NavGeometry, ep: Episode, count: int, seed: int, steps: int, seconds: float
) -> int:
    """Of ``steps`` action steps of ``seconds`` each, how many end with a person's body overlapping the Zone 3
    of the episode's goal, ``count`` people reset from ``seed`` and the robot standing at its start (a
    one-line CrowdError when the scene cannot hold them)."""
    crowd, start = _crowd(spec, nav, ep, count, seed)
    zone = spec.get(ep["object_id"]).placed().zone3()
    shapely.prepare(zone)
    n = 0
    for _ in range(steps):
        crowd.advance(seconds, start)
        n += overlaps_zone(zone, crowd.pos)
    return n


def crowd_paths(spec: SceneSpec, nav: NavGeometry, ep: Episode, seconds: float) -> np.ndarray:
    """(count, steps + 1, 2): where each person of a busy episode is at its start and after each step of its
    step limit, the robot standing at its start (what the maps draw)."""
    p = ep["people"]
    crowd, start = _crowd(spec, nav, ep, p["count"], p["seed"])
    out = [crowd.pos.copy()]
    for _ in range(p["steps"]):
        crowd.advance(seconds, start)
        out.append(crowd.pos.copy())
    return np.stack(out, axis=1)


@dataclass(frozen=True)
class BusyEpisodes:
    """``base``'s episodes, each with a crowd of 1 to ``max_people`` (uniform; at most one fewer than the
    faces people can walk to, so one is always free to walk to, and fewer where the scene cannot place them
    away from the start: the resample) and its ``occupied_steps`` over ``steps`` steps of ``seconds``.

    A crowd that occupies the goal's face for the whole step limit (strict success impossible) is drawn
    again, up to :data:`OCCUPIED_ATTEMPTS` crowd seeds; so is one that never occupies it for every
    ``occupied_every``-th episode (ids 0, k, 2k, ...), so at least that share of a split has its goal's face
    occupied for part of the episode. After the last attempt its crowd is kept as drawn."""

    base: Sampler
    max_people: int
    steps: int
    seconds: float
    occupied_every: int = 3

    def draw(
        self, scenes: SceneSamplers, spec: SceneSpec, n: int, seed: int, cross_room: bool = False
    ) -> list[Episode]:
        eps = self.base.draw(scenes, spec, n, seed, cross_room)
        nav = scenes.get(spec).nav
        rng = np.random.default_rng([seed, stable_seed("people", spec.name)])
        counts = rng.integers(1, self.max_people + 1, len(eps)).tolist()
        for k, (ep, count) in enumerate(zip(eps, counts)):
            want_busy = k % self.occupied_every == 0
            for attempt in range(OCCUPIED_ATTEMPTS):
                crowd_seed = stable_seed("people", seed, spec.name, ep["episode_id"], attempt)
                count, busy = self._fit(spec, nav, ep, count, crowd_seed)
                if busy < self.steps and (busy > 0 or not want_busy):
                    break
            ep["people"] = {"count": count, "seed": crowd_seed, "occupied_steps": busy, "steps": self.steps}
        return eps

    def _fit(self, spec, nav, ep, count: int, crowd_seed: int) -> tuple[int, int]:
        """The largest count up to ``count`` the scene holds around this start, and its occupied steps."""
        faces = len(stations(spec, nav, ep["start_position"][:2]).ids)
        for c in range(min(count, faces - 1), 0, -1):
            try:
                return c, occupied_steps(spec, nav, ep, c, crowd_seed, self.steps, self.seconds)
            except CrowdError:
                continue
        raise CrowdError(
            f"scene '{spec.name}': no instrument face where a person can stand away from the start of "
            f"episode {ep['episode_id']}",
            field="people",
            fix="use a scene with more instruments",
        )
