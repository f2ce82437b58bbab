"""Which episode a reset starts: the cursor's order; a batched env's partial resets stay in their scene."""

from biovln_ms.episodes.source import EpisodeCursor, EpisodeSource, seed_position


class _Episodes(EpisodeSource):
    def __init__(self, scenes: dict[str, int]) -> None:
        self.episodes = [{"scene_id": s, "episode_id": str(k)} for s, n in scenes.items() for k in range(n)]


def test_shuffle_keeps_each_scenes_episodes_together_and_is_fixed():
    source = _Episodes({"a": 3, "b": 4, "c": 2})
    order = EpisodeCursor(source, shuffle=True).order
    assert order == EpisodeCursor(source, shuffle=True).order and sorted(order) == list(range(9))
    scenes = [source.episodes[i]["scene_id"] for i in order]
    runs = [s for k, s in enumerate(scenes) if k == 0 or s != scenes[k - 1]]
    assert sorted(runs) == ["a", "b", "c"]  # each scene once: rebuilt once per pass


def test_visits_take_that_many_of_each_scenes_episodes_in_turn_in_the_same_shuffle():
    source = _Episodes({"a": 3, "b": 4, "c": 2})
    together = EpisodeCursor(source, shuffle=True).order
    order = EpisodeCursor(source, shuffle=True, visit=2).order
    assert sorted(order) == list(range(9))
    scenes = [source.episodes[i]["scene_id"] for i in order]
    runs = [s for k, s in enumerate(scenes) if k == 0 or s != scenes[k - 1]]
    first = [s for k, s in enumerate(runs) if s not in runs[:k]]
    assert runs == first + [s for s in first if s != "c"]  # two visits each; c has only 2 episodes
    for s in "abc":  # each scene's episodes in the same order as without visits
        assert [i for i in order if scenes[order.index(i)] == s] == [
            i for i in together if source.episodes[i]["scene_id"] == s
        ]


def test_next_in_scene_cycles_through_that_scenes_episodes_in_the_cursors_order():
    source = _Episodes({"a": 3, "b": 4})
    cursor = EpisodeCursor(source, shuffle=True)
    in_b = [i for i in cursor.order if source.episodes[i]["scene_id"] == "b"]
    assert [cursor.next_in_scene("b") for _ in range(6)] == in_b + in_b[:2]
    assert cursor.next_in_scene("a") == next(i for i in cursor.order if source.episodes[i]["scene_id"] == "a")
    # the scene cycles do not move the cursor's own position (the next full reset)
    assert cursor.select(None, {}) == cursor.order[0]


def test_consecutive_seeds_start_far_apart_so_vector_envs_play_different_episodes():
    """gymnasium's and SB3's vector envs seed env i with seed + i: their first 100 episodes are disjoint."""
    source = _Episodes({f"s{k}": 20 for k in range(50)})
    played = []
    for seed in range(4):
        cursor = EpisodeCursor(source, shuffle=True)
        played.append({cursor.select(seed, {})} | {cursor.select(None, {}) for _ in range(99)})
    assert all(len(p) == 100 for p in played)
    assert all(not (played[i] & played[j]) for i in range(4) for j in range(i))
    cursor = EpisodeCursor(source, shuffle=True)
    assert cursor.select(0, {}) == cursor.order[0] and cursor.select(7, {}) == cursor.select(7, {})


def test_every_position_is_some_seeds_and_seeds_of_any_size_work():
    for n in (1, 2, 3, 10, 28):
        assert {seed_position(s, n) for s in range(10 * n)} == set(range(n))
    assert 0 <= seed_position(2**70 + 5, 1000) < 1000 and 0 <= seed_position(-3, 1000) < 1000
