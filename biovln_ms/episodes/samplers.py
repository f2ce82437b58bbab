"""How episodes are drawn in a scene: one :class:`Sampler` protocol, three kinds of episode.

A split of a dataset (:class:`~biovln_ms.episodes.writer.SplitPlan`) and a scene generated on the fly
(:class:`~biovln_ms.episodes.source.GeneratedEpisodes`) each hold a sampler; the dataset build and the env
call it the same way and know no kind of episode:

* :class:`SingleGoalEpisodes`: one goal object each (the paper's), started in another room where the scene
  asks for cross-room episodes;
* :class:`AnyInstanceEpisodes`: the goal is a category and reaching any instance counts, a share of the
  starts drawn far (the Hard track; the molecular-biology splits draw none far);
* :class:`ProtocolEpisodes`: a lab protocol's K ordered goals and its instruction.

A scene's geometry (navigable floor, goals and view points, start regions) is built once, however many
splits draw in it: samplers take their scene's episode sampler from a :class:`SceneSamplers` cache.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol, TypeVar

from biovln_ms.episodes.generator import EpisodeError, EpisodeSampler
from biovln_ms.episodes.schema import Episode
from biovln_ms.protocols.episodes import ProtocolSampler
from biovln_ms.protocols.library import ProtocolLibrary, load_protocols
from biovln_ms.scene.spec import SceneSpec

_S = TypeVar("_S", bound=EpisodeSampler)


class SceneSamplers:
    """The episode sampler of each scene, by scene name, so a scene's geometry is built once. A sampler of
    another kind for the same scene (a protocol sampler after a plain one) replaces it and reuses its
    navigation geometry."""

    def __init__(self) -> None:
        self._by_scene: dict[str, EpisodeSampler] = {}

    def get(self, spec: SceneSpec, kind: type[_S] = EpisodeSampler) -> _S:
        sampler = self._by_scene.get(spec.name)
        if not isinstance(sampler, kind):
            sampler = kind(spec, None if sampler is None else sampler.nav)
            self._by_scene[spec.name] = sampler
        return sampler


class Sampler(Protocol):
    """Draws a scene's episodes: the same seed gives the same episodes."""

    def draw(
        self, scenes: SceneSamplers, spec: SceneSpec, n: int, seed: int, cross_room: bool = False
    ) -> list[Episode]:
        """``n`` episodes in ``spec``'s scene (its sampler from ``scenes``) from ``seed``, their ids ``"0"``
        up; ``cross_room``: start each in a room other than its goal's."""
        ...


def _no_cross_room(kind: str, spec: SceneSpec, cross_room: bool) -> None:
    if cross_room:
        raise EpisodeError(
            f"scene '{spec.name}': {kind} have no cross-room starts",
            field="cross_room",
            fix="plan the scene with cross_room=False, or draw single-goal episodes (SingleGoalEpisodes)",
        )


@dataclass(frozen=True)
class SingleGoalEpisodes:
    """Single-goal episodes (``EpisodeSampler.episodes``): one goal object each, cycling over the scene's
    goal objects."""

    def draw(
        self, scenes: SceneSamplers, spec: SceneSpec, n: int, seed: int, cross_room: bool = False
    ) -> list[Episode]:
        return scenes.get(spec).episodes(n, seed=seed, cross_room=cross_room)


@dataclass(frozen=True)
class AnyInstanceEpisodes:
    """Any-instance episodes (``EpisodeSampler.any_instance_episodes``): every instance of the goal category
    is a goal; ``hard_share`` of the starts are drawn for a geodesic over 6 m."""

    hard_share: float

    def draw(
        self, scenes: SceneSamplers, spec: SceneSpec, n: int, seed: int, cross_room: bool = False
    ) -> list[Episode]:
        _no_cross_room("any-instance episodes", spec, cross_room)
        return scenes.get(spec).any_instance_episodes(n, seed=seed, hard_share=self.hard_share)


@dataclass(frozen=True)
class ProtocolEpisodes:
    """Protocol episodes (``ProtocolSampler.protocol_episodes``) of ``library``; None: the library loaded
    when drawing (the shipped protocols and the user's, ``load_protocols``)."""

    library: ProtocolLibrary | None = None

    def draw(
        self, scenes: SceneSamplers, spec: SceneSpec, n: int, seed: int, cross_room: bool = False
    ) -> list[Episode]:
        _no_cross_room("protocol episodes", spec, cross_room)
        library = load_protocols() if self.library is None else self.library
        return scenes.get(spec, ProtocolSampler).protocol_episodes(n, seed, library)
