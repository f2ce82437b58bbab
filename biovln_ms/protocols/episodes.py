"""Protocol episodes: K = 2-5 ordered goals in one scene, a start, and the English instruction.

An episode of protocol P in a scene is drawn with one seeded generator, in this order:

1. **Visits**: an admissible order of P (``Protocol.sample_order``: any-order groups shuffled), each visit one
   object of its category drawn among the scene's *drawable* objects: goal objects (an Eq. 1 goal and a
   success radius r) that an instruction can single out (``instructions.describable``). Furniture that is
   no goal and objects no relation singles out are never drawn: the documented resample.
2. **Start**: drawn as a single-goal episode's start for the first goal (``EpisodeSampler``: at least
   1.0 m from obstacles, outside r, at least r + 1.0 m from it along the floor; its fallback band where
   no such floor exists, recorded on the episode), and outside every later goal's success radius too. A
   draw of visits with no such start (under 0.01 m^2 of floor, or none in 100 draws) is redrawn, up to 20
   times; a protocol none of whose draws has one is left out of the scene's cycle from then on.
3. **Instruction**: the grammar's text for those visits (``instructions.instruction``), which checks that it
   reads back to exactly them, and that fits the vocabulary's fixed lengths (``vocabulary``).
4. **Route**: the geodesic legs start -> g1 -> ... -> gK; the route length L (their sum) is PPL's
   reference path.

A scene *hosts* a protocol when every category it visits has a drawable object. Episodes cycle over the
hosted protocols (shuffled once per scene); a scene hosting none raises :class:`EpisodeError` naming what it
lacks (generate it with ``required_categories``, or take another seed). The episode is a single-goal
episode's record (``goals`` in visit order; ``object_category`` / ``object_id`` the first visit; ``info``
with ``geodesic_distance`` = L and its difficulty tier) plus a ``protocol`` object: ``id``, ``k``,
``instruction``, per-visit ``purposes`` and ``relations`` (None: the category occurs once),
``needs_relation`` (how many visits needed one), ``legs`` and ``route_length``.
"""

from __future__ import annotations

import math
from collections.abc import Iterable

import numpy as np
import shapely
from shapely.ops import unary_union

from biovln_ms.episodes.generator import (
    EpisodeError,
    EpisodeSampler,
    difficulty,
    keeps_start_rule,
    stable_seed,
    yaw_to_quat,
)
from biovln_ms.episodes.schema import Episode, Goal
from biovln_ms.protocols.instructions import describable, instruction
from biovln_ms.protocols.library import Protocol, ProtocolLibrary, load_protocols
from biovln_ms.protocols.vocabulary import load_vocabulary
from biovln_ms.scene.spec import SceneSpec

#: the stream of a scene's protocol episodes (single-goal episodes use [scene, seed], the Hard track 1)
PROTOCOL_STREAM = 2
#: draws of an episode's visits (order and objects) before a protocol is declared impossible in a scene
MAX_VISIT_DRAWS = 20
#: m^2: the least start floor, outside the later goals' radii, for a draw of visits to be kept
MIN_START_AREA = 0.01
#: starts drawn for one draw of visits before the draw is given up
ROUTE_START_ATTEMPTS = 100


def _r6(values) -> list[float]:
    return [round(float(x), 6) for x in values]


def drawable_objects(scene: SceneSpec) -> dict[str, list[str]]:
    """Category -> ids of the scene's goal objects an instruction can single out, in scene order."""
    out: dict[str, list[str]] = {}
    for o in scene.goal_objects():
        if describable(scene, o.id):
            out.setdefault(o.category, []).append(o.id)
    return out


def hosted_protocols(scene: SceneSpec, library: Iterable[Protocol]) -> list[Protocol]:
    """The protocols of ``library`` whose every category has a drawable object in ``scene``."""
    pool = drawable_objects(scene)
    return [p for p in library if all(c in pool for c in p.categories())]


class ProtocolSampler(EpisodeSampler):
    """Samples protocol episodes in one scene (the single-goal sampler's goals and starts)."""

    def protocol_episodes(self, n: int, seed: int, library: ProtocolLibrary | None = None) -> list[Episode]:
        """``n`` episodes cycling over the protocols of ``library`` (default: the shipped ones) the scene
        hosts, shuffled; every draw from ``numpy.random.default_rng([scene, seed, PROTOCOL_STREAM])``."""
        library = load_protocols(env=False) if library is None else library
        pool = drawable_objects(self.spec)
        hosted = [p for p in library if all(c in pool for c in p.categories())]
        if not hosted:
            have = ", ".join(sorted(pool)) or "none"
            raise EpisodeError(
                f"scene '{self.spec.name}' hosts no protocol: its drawable categories are {have}",
                field="scene",
                fix="generate it with required_categories=<a protocol's categories>, or take another seed",
            )
        rng = np.random.default_rng([stable_seed(self.spec.name), seed, PROTOCOL_STREAM])
        order = [hosted[i] for i in rng.permutation(len(hosted))]
        out: list[Episode] = []
        while len(out) < n:
            if not order:
                raise EpisodeError(
                    f"scene '{self.spec.name}': no protocol it hosts has start floor for its first goal "
                    f"outside the success radii of its later goals",
                    field="scene",
                    fix="give the scene more free floor away from its instruments, or take another seed",
                )
            protocol = order[len(out) % len(order)]
            episode = self._episode(protocol, pool, rng, str(len(out)))
            if episode is None:  # impossible in this scene: left out of its cycle from here on
                order.remove(protocol)
            else:
                out.append(episode)
        return out

    def _episode(
        self, protocol: Protocol, pool: dict[str, list[str]], rng: np.random.Generator, episode_id: str
    ) -> Episode | None:
        """One episode of ``protocol``, or None when no draw of its visits leaves start floor."""
        for _ in range(MAX_VISIT_DRAWS):
            visits = protocol.sample_order(rng)
            ids = [pool[v.category][int(rng.integers(len(pool[v.category])))] for v in visits]
            targets = [self._targets[i] for i in ids]
            region, clearance = self.start_region(targets[0])
            later = unary_union([shapely.Point(t["position"][:2]).buffer(t["radius"]) for t in targets[1:]])
            region = region.difference(later)
            drawn = self._route_start(region, targets, rng) if region.area >= MIN_START_AREA else None
            if drawn is not None:
                break
        else:
            return None
        start, first_leg = drawn
        instr = instruction(protocol, self.spec, ids, rng)
        vocab = load_vocabulary()
        vocab.encode(instr.text)  # both raise InstructionTooLongError if it does not fit
        vocab.encode_text(instr.text)
        yaw = float(rng.uniform(-math.pi, math.pi))
        legs = [first_leg]
        for a, b in zip(targets, targets[1:]):
            leg = self.nav.geodesic_distance(a["position"][:2], b["position"][:2])
            if not math.isfinite(leg):
                raise EpisodeError(
                    f"scene '{self.spec.name}': no path from the goal of '{a['object_id']}' to that of "
                    f"'{b['object_id']}'",
                    field=b["object_id"],
                    fix="regenerate the scene (its goals must be mutually reachable)",
                )
            legs.append(leg)
        route = float(sum(legs))
        first = np.asarray(targets[0]["position"][:2])
        return {
            "episode_id": episode_id,
            "scene_id": self.spec.name,
            "start_position": _r6([start[0], start[1], 0.0]),
            "start_rotation": _r6(yaw_to_quat(yaw)),
            "object_category": targets[0]["object_category"],
            "object_id": targets[0]["object_id"],
            "goals": targets,
            "info": {
                "geodesic_distance": round(route, 6),
                "euclidean_distance": round(float(np.linalg.norm(first - start)), 6),
                "difficulty": difficulty(route),
                "start_clearance": round(clearance, 6),
                "start_clearance_fallback": clearance < self.min_start_clearance,
                "cross_room": False,
            },
            "protocol": {
                "id": protocol.id,
                "k": len(ids),
                "instruction": instr.text,
                "purposes": [v.purpose for v in visits],
                "relations": [t.relation for t in instr.targets],
                "needs_relation": instr.needs_relation,
                "legs": _r6(legs),
                "route_length": round(route, 6),
            },
        }

    def _route_start(
        self, region, targets: list[Goal], rng: np.random.Generator
    ) -> tuple[np.ndarray, float] | None:
        """A start in ``region`` (the first goal's start region less the later goals' discs) that keeps the
        single-goal rule for the first goal and lies outside every goal's success radius (checked exactly:
        the discs are polygons), and its geodesic to the first goal; None after ROUTE_START_ATTEMPTS draws."""
        goals = np.array([t["position"][:2] for t in targets])
        radii = np.array([t["radius"] for t in targets])
        for _ in range(ROUTE_START_ATTEMPTS):
            start = np.round(self.sample_in(region, rng), 6)  # as stored, so the stored start keeps the rule
            euclidean = np.linalg.norm(goals - start, axis=1)
            if np.any(euclidean <= radii):
                continue
            geo = self.nav.geodesic_distance(start, goals[0])
            if keeps_start_rule(geo, float(euclidean[0]), float(radii[0])):
                return start, geo
        return None
