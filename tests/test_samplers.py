"""One sampler protocol for every kind of episode: a split plan and a generated scene draw with the same
objects, a scene's geometry is built once per build, what they draw is the public episode schema, and a
sampler of one's own builds a dataset like the shipped ones."""

from __future__ import annotations

from dataclasses import dataclass

import pytest

from biovln_ms.episodes.dataset import EpisodeDataset
from biovln_ms.episodes.generator import EpisodeError, EpisodeSampler
from biovln_ms.episodes.samplers import (
    AnyInstanceEpisodes,
    ProtocolEpisodes,
    Sampler,
    SceneSamplers,
    SingleGoalEpisodes,
)
from biovln_ms.episodes.schema import EPISODES, Episode
from biovln_ms.episodes.source import GeneratedEpisodes
from biovln_ms.episodes.writer import SplitPlan, write_dataset
from biovln_ms.protocols import load_protocols
from biovln_ms.protocols.episodes import ProtocolSampler
from biovln_ms.scene.generator import generate_scene

LIBRARY = load_protocols(env=False)


@pytest.fixture(scope="module")
def two_room():
    return generate_scene("two_room", 700)


def test_a_scene_sampler_is_built_once_and_a_protocol_one_reuses_its_geometry(two_room):
    scenes = SceneSamplers()
    plain = scenes.get(two_room)
    assert type(plain) is EpisodeSampler and scenes.get(two_room) is plain
    protocol = scenes.get(two_room, ProtocolSampler)
    assert isinstance(protocol, ProtocolSampler) and protocol.nav is plain.nav
    assert scenes.get(two_room) is protocol  # a protocol sampler is a plain one too


def test_each_sampler_draws_what_its_episode_sampler_draws_in_the_schema(two_room):
    single = generate_scene("single_room", 500)
    kinds = [
        (SingleGoalEpisodes(), two_room, True, EpisodeSampler(two_room).episodes(4, seed=5, cross_room=True)),
        (AnyInstanceEpisodes(0.5), single, False, EpisodeSampler(single).any_instance_episodes(4, 5, 0.5)),
        (
            ProtocolEpisodes(LIBRARY),
            two_room,
            False,
            ProtocolSampler(two_room).protocol_episodes(4, 5, LIBRARY),
        ),
    ]
    scenes = SceneSamplers()
    for sampler, spec, cross, expected in kinds:
        eps = sampler.draw(scenes, spec, 4, 5, cross_room=cross)
        assert eps == expected, sampler
        EPISODES.validate_python(eps)


@pytest.mark.parametrize("sampler", [AnyInstanceEpisodes(0.5), ProtocolEpisodes(LIBRARY)])
def test_cross_room_starts_are_single_goal_episodes_only(two_room, sampler):
    with pytest.raises(EpisodeError, match="no cross-room starts") as e:
        sampler.draw(SceneSamplers(), two_room, 2, 0, cross_room=True)
    assert e.value.field == "cross_room" and "\n" not in str(e.value)


def test_a_generated_scene_draws_with_the_same_samplers():
    default = GeneratedEpisodes("single_room", 3, n=3)
    assert default.episodes == EpisodeSampler(default.spec("")).episodes(3, seed=3)
    protocols = GeneratedEpisodes("two_room", 700, n=2, sampler=ProtocolEpisodes(LIBRARY))
    assert all("protocol" in ep for ep in protocols.episodes)
    assert SplitPlan("s").sampler == SingleGoalEpisodes()


@dataclass(frozen=True)
class _FirstGoalOnly:
    """A sampler of one's own: single-goal episodes, every other one kept."""

    def draw(self, scenes: SceneSamplers, spec, n: int, seed: int, cross_room: bool = False) -> list[Episode]:
        eps = scenes.get(spec).episodes(2 * n, seed=seed, cross_room=cross_room)[::2]
        return [{**ep, "episode_id": str(k)} for k, ep in enumerate(eps)]


def test_a_sampler_of_ones_own_builds_a_dataset(tmp_path, two_room):
    sampler: Sampler = _FirstGoalOnly()
    write_dataset(
        tmp_path / "ds", [SplitPlan("mine", [(two_room, 3, False)], sampler=sampler)], progress=False
    )
    eps = list(EpisodeDataset(tmp_path / "ds").episodes("mine"))
    assert [e["episode_id"] for e in eps] == ["0", "1", "2"]
