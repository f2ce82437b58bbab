"""The episode: one typed schema from the episode file to the env.

Samplers (:mod:`biovln_ms.episodes.samplers`) return :class:`Episode` objects, episode files hold them
(``{"episodes": [...]}``), :class:`~biovln_ms.episodes.dataset.EpisodeDataset` validates them against these
types on loading (``EPISODES``) and the env reads them. They are ``TypedDict``s, not models: an episode is
the JSON object itself, validated but never converted, so a loaded episode is exactly what was stored.

Validation is strict (no ``"1.5"`` -> 1.5 or ``true`` -> 1 coercion), refuses NaN and infinities, keeps
coordinates within ``MAX_COORDINATE`` of the origin and ignores unknown keys. Episode, scene and object
ids and categories are ids (``biovln_ms.limits.Identifier``): they become file names (hand-offs,
recordings). Which scene an episode belongs to, whether its category is the catalog's, and whether a
protocol's lists are K long are checked by the loader, which knows the file and the catalog.
"""

from __future__ import annotations

import math
from typing import Annotated, Literal

from pydantic import AfterValidator, ConfigDict, Field, TypeAdapter, with_config
from typing_extensions import NotRequired, TypedDict

from biovln_ms.constants import MAX_VISITS, MIN_VISITS
from biovln_ms.limits import MAX_ID_LENGTH, Identifier
from biovln_ms.people.crowd import MAX_PEOPLE
from biovln_ms.scene.spec import MAX_COORDINATE

MAX_GOALS = 64  # per episode
MAX_STEP_LIMIT = 1_000_000  # an episode's step limit (``max_episode_steps``' bound)
MAX_VIEW_POINTS = 1024  # per goal

#: the validation of every dataset file's schema: strict types, finite numbers
STRICT = ConfigDict(strict=True, allow_inf_nan=False)
Count = Annotated[int, Field(ge=0)]
_Coord = Annotated[float, Field(ge=-MAX_COORDINATE, le=MAX_COORDINATE)]
_Distance = Annotated[float, Field(ge=0)]


def _unit_quaternion(q: list[float]) -> list[float]:
    if abs(math.hypot(*q) - 1.0) > 1e-3:
        raise ValueError("must be a unit quaternion [w, x, y, z]")
    return q


_Vec2 = Annotated[list[_Coord], Field(min_length=2, max_length=2)]
_Vec3 = Annotated[list[_Coord], Field(min_length=3, max_length=3)]
_Quat = Annotated[list[float], Field(min_length=4, max_length=4), AfterValidator(_unit_quaternion)]


@with_config(STRICT)
class AgentState(TypedDict):
    """A pose: ``position`` [x, y, z] (Z up) and ``rotation``, a wxyz unit quaternion (SAPIEN's)."""

    position: _Vec3
    rotation: _Quat


@with_config(STRICT)
class ViewPoint(TypedDict):
    """A navigable pose inside the goal's Zone 3 and success radius, facing the instrument."""

    agent_state: AgentState


@with_config(STRICT)
class Goal(TypedDict):
    """One goal object: its Eq. 1 goal snapped to navigable floor (``position``), the success radius, the
    unsnapped Eq. 1 goal and its view points."""

    position: _Vec3
    radius: Annotated[float, Field(gt=0, le=MAX_COORDINATE)]
    object_id: Identifier
    object_category: Identifier
    eq1_goal: _Vec2
    view_points: Annotated[list[ViewPoint], Field(max_length=MAX_VIEW_POINTS)]


@with_config(STRICT)
class SamplerInfo(TypedDict):
    """An episode's ``info``, what its sampler measured: geodesic (a protocol's: its route length) and
    straight-line distance from the start, the difficulty tier, the start's clearance (and whether the
    fallback band gave it), and, where any instance counts, the number of ``instances`` and whether the
    start was drawn hard. (A policy's view of an episode is ``biovln_ms.task_config.EpisodeInfo``.)"""

    geodesic_distance: _Distance
    euclidean_distance: _Distance
    difficulty: Literal["easy", "medium", "hard"]
    start_clearance: _Coord
    start_clearance_fallback: bool
    cross_room: bool
    any_instance: NotRequired[bool]  # every goal is an instance of the category; any counts
    instances: NotRequired[Annotated[int, Field(ge=1, le=MAX_GOALS)]]
    drawn_hard: NotRequired[bool]  # the start was drawn for a geodesic over 6 m


@with_config(STRICT)
class ProtocolInfo(TypedDict):
    """A protocol episode's (``biovln_ms.protocols.episodes``): its K goals are visited in order."""

    id: Annotated[str, Field(max_length=MAX_ID_LENGTH, pattern=r"^[a-z][a-z0-9_]*$")]
    k: Annotated[int, Field(ge=MIN_VISITS, le=MAX_VISITS)]
    instruction: Annotated[str, Field(min_length=1, max_length=2**16)]
    purposes: Annotated[list[str], Field(min_length=MIN_VISITS, max_length=MAX_VISITS)]
    relations: Annotated[list[str | None], Field(min_length=MIN_VISITS, max_length=MAX_VISITS)]
    needs_relation: Count
    legs: Annotated[list[_Distance], Field(min_length=MIN_VISITS, max_length=MAX_VISITS)]
    route_length: _Distance


@with_config(STRICT)
class PeopleInfo(TypedDict):
    """A busy split's episode (``biovln_ms.people.episodes``): its own crowd, ``count`` people reset from
    crowd ``seed``, and the ``steps`` of its step limit after which a person overlapped the goal's Zone 3
    (``occupied_steps``, the robot standing at its start)."""

    count: Annotated[int, Field(ge=1, le=MAX_PEOPLE)]
    seed: Annotated[int, Field(ge=0, lt=2**32)]
    occupied_steps: Count
    steps: Annotated[int, Field(ge=1, le=MAX_STEP_LIMIT)]


@with_config(STRICT)
class Episode(TypedDict):
    """A Habitat-style episode: a start pose in a scene and its goals (one; every instance of the category
    where any counts; or a protocol's K in visit order), ``object_category`` / ``object_id`` the first."""

    episode_id: Identifier
    scene_id: Identifier
    start_position: _Vec3
    start_rotation: _Quat
    object_category: Identifier
    object_id: Identifier
    goals: Annotated[list[Goal], Field(min_length=1, max_length=MAX_GOALS)]
    info: SamplerInfo
    protocol: NotRequired[ProtocolInfo]  # a protocol split's episode: K ordered goals
    people: NotRequired[PeopleInfo]  # a busy split's episode: its crowd


#: validates the episode list of an episode file
EPISODES = TypeAdapter(list[Episode])
