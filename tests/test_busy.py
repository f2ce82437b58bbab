"""The busy splits and variants (people in the lab, part 2): episodes carrying their own crowd (count, crowd
seed, occupied steps), their share of busy goals, held-out seeds, a small busy dataset's stats, the env
taking an episode's crowd (and its figures count from the split), and the variants' registration."""

from __future__ import annotations

from dataclasses import replace

import gymnasium as gym
import numpy as np
import pytest

import biovln_ms  # noqa: F401
from biovln_ms.episodes.dataset import EpisodeDataset
from biovln_ms.episodes.samplers import SceneSamplers, SingleGoalEpisodes
from biovln_ms.episodes.schema import EPISODES
from biovln_ms.episodes.writer import SplitPlan, write_dataset
from biovln_ms.errors import BioVLNError
from biovln_ms.people.crowd import Crowd, stations, step_seconds
from biovln_ms.people.episodes import BusyEpisodes, occupied_steps
from biovln_ms.scene.generator import generate_scene
from biovln_ms.splits import BUSY_SPLITS, FOUR_CATEGORIES, HARD_SPLITS, MOLBIO_SPLITS, PROTOCOL_SPLITS
from biovln_ms.splits import held_out_seeds
from biovln_ms.variants import BUSY_ENV, BUSY_STRICT_ENV, RL_BUSY_ENV, RL_ENV, VARIANTS, WITH_PEOPLE

CPU = dict(sim_backend="physx_cpu", render_backend="cpu", obs_mode="none")
STEPS = 80  # a short step limit keeps the model runs quick
SAMPLER = BusyEpisodes(SingleGoalEpisodes(), 4, STEPS, step_seconds(0.25, 30.0))


@pytest.fixture(scope="module")
def room():
    return generate_scene("single_room", 1000, required_categories=FOUR_CATEGORIES)


@pytest.fixture(scope="module")
def drawn(room):
    return SAMPLER.draw(SceneSamplers(), room, 9, seed=3)


def test_busy_episodes_carry_a_crowd_and_are_deterministic(room, drawn):
    EPISODES.validate_python(drawn)  # the schema takes them
    again = SAMPLER.draw(SceneSamplers(), room, 9, seed=3)
    assert drawn == again
    counts = [e["people"]["count"] for e in drawn]
    assert all(1 <= c <= 4 for c in counts) and len(set(counts)) > 1
    for e in drawn:
        p = e["people"]
        assert p["steps"] == STEPS and 0 <= p["occupied_steps"] < STEPS  # the face is free for a while
    busy = [e["people"]["occupied_steps"] > 0 for e in drawn]
    assert all(busy[::3]) and sum(busy) >= len(busy) / 3  # every third, at least: a busy goal


def test_occupied_steps_replay_from_the_episode(room, drawn):
    nav = SceneSamplers().get(room).nav
    for e in drawn[:3]:
        p = e["people"]
        again = occupied_steps(room, nav, e, p["count"], p["seed"], STEPS, SAMPLER.seconds)
        assert again == p["occupied_steps"]


def test_a_crowd_of_fewer_people_than_slots_is_the_same_crowd(room, drawn):
    """An episode's crowd does not depend on how many figures the env has."""
    nav = SceneSamplers().get(room).nav
    e = next(e for e in drawn if e["people"]["count"] < 4)
    start, p = np.asarray(e["start_position"][:2]), e["people"]
    st = stations(room, nav, start)
    exact, padded = Crowd(p["count"]), Crowd(6)
    exact.reset(nav, st, start, nav.radius, p["seed"], room.name)
    padded.reset(nav, st, start, nav.radius, p["seed"], room.name, p["count"])
    assert padded.present.sum() == p["count"]
    for _ in range(40):
        exact.advance(0.5, start)
        padded.advance(0.5, start)
        assert np.array_equal(exact.pos, padded.pos[: p["count"]])
    assert (padded.pos[p["count"] :] > 1e3).all()  # the absent ones, far from every scene


def test_busy_seeds_are_held_out_and_used_by_no_other_split():
    held = held_out_seeds()
    others = {(t, s) for rows in HARD_SPLITS.values() for t, s, _ in rows}
    others |= {("molecular_biology", f + i) for f, n in MOLBIO_SPLITS.values() for i in range(n)}
    busy = [(t, s) for rows in BUSY_SPLITS.values() for t, s in rows]
    assert len(set(busy)) == len(busy) and len({t for t, _ in busy}) >= 3  # several templates
    for t, s in busy:
        assert s in held[t] and (t, s) not in others
        assert not any(f <= s < f + 50 for f, _ in PROTOCOL_SPLITS.values())
        assert not 0 <= s < 300  # the paper's full / train seeds and the two-room scenes


@pytest.fixture(scope="module")
def dataset(tmp_path_factory, room):
    out = tmp_path_factory.mktemp("busy") / "ds"
    write_dataset(out, [SplitPlan("busy_val", [(room, 6, False)], sampler=SAMPLER)], progress=False)
    return out


def test_a_busy_dataset_loads_and_its_stats_count_people(dataset):
    ds = EpisodeDataset(dataset)
    st = ds.stats("busy_val")["people"]
    eps = list(ds.episodes("busy_val"))
    assert sum(st["count"].values()) == 6 and st["mean_count"] == round(
        sum(e["people"]["count"] for e in eps) / 6, 2
    )
    assert st["occupied_episodes"] >= 100 / 3


def test_the_env_takes_the_episodes_crowd_and_its_figures_from_the_split(dataset):
    eps = list(EpisodeDataset(dataset).episodes("busy_val"))
    most = max(e["people"]["count"] for e in eps)
    e = gym.make("BioVLN-OpFace-v0", split="busy_val", dataset=str(dataset), **CPU)
    try:
        u = e.unwrapped
        assert u.cfg.people == most  # figures for the split's largest crowd
        for k in (0, 1):
            e.reset(options={"episode_index": k})
            p = u.current_episode["people"]
            crowd = u._people.crowds[0]
            assert int(crowd.present.sum()) == p["count"] and crowd.seed == p["seed"]
            info = e.step(0)[4]
            assert float(info["person_distance"][0]) < 100.0  # the absent ones are not the nearest
    finally:
        e.close()
    with pytest.raises(BioVLNError, match="field 'people'.*crowds of up to") as err:
        gym.make("BioVLN-OpFace-v0", split="busy_val", dataset=str(dataset), people=most - 1, **CPU)
    assert "\n" not in str(err.value)


def test_the_busy_variants_are_registered():
    for uid in (BUSY_ENV, BUSY_STRICT_ENV, RL_BUSY_ENV):
        assert uid in gym.registry and VARIANTS[uid].people == 4
        assert VARIANTS[uid].default_split == "busy_val"
    assert VARIANTS[BUSY_STRICT_ENV].success_measure == "strict_success"
    # each variant's counterpart with people differs from it in its people and default split only
    for plain, busy in WITH_PEOPLE.items():
        assert (
            replace(VARIANTS[busy], people=0, default_split=VARIANTS[plain].default_split) == VARIANTS[plain]
        ), busy
    assert WITH_PEOPLE[RL_ENV] == RL_BUSY_ENV


def test_people_zero_runs_the_busy_episodes_in_an_empty_lab(dataset):
    e = gym.make("BioVLN-OpFace-v0", split="busy_val", dataset=str(dataset), people=0, **CPU)
    try:
        e.reset(options={"episode_index": 0})
        info = e.step(0)[4]
        assert e.unwrapped._people is None and "person_distance" not in info
    finally:
        e.close()


def test_an_episode_crowd_the_scene_cannot_hold_is_one_line(dataset):
    from biovln_ms.episodes.source import DatasetEpisodes

    source = DatasetEpisodes("busy_val", dataset)
    source.episodes[0]["people"]["count"] = 8  # more than the scene's faces: an edited dataset
    with pytest.raises(BioVLNError, match="field 'people.count'.*episode 0 of scene .* brings 8") as err:
        env = gym.make("BioVLN-OpFace-v0", episodes=source, people=8, **CPU)  # ManiSkill resets on making it
        env.reset(options={"episode_index": 0})  # (its seed may have started another scene)
    assert "\n" not in str(err.value) and "rebuild the dataset" in str(err.value)


def test_a_face_without_a_free_path_is_never_a_persons_walk(room):
    """The resample: a face no route reaches (here one outside the lab) is skipped for another."""
    from biovln_ms.people.crowd import Stations

    nav = SceneSamplers().get(room).nav
    start = np.array(next(iter(SAMPLER.draw(SceneSamplers(), room, 1, seed=0)))["start_position"][:2])
    st = stations(room, nav, start)
    far = Stations((*st.ids, "nowhere"), np.vstack([st.stand, [[100.0, 100.0]]]), np.append(st.yaw, 0.0))
    crowd = Crowd(1)
    crowd.reset(nav, st, start, nav.radius, 5, room.name)
    crowd.st = far  # the same people, one face more that no path reaches
    for _ in range(30):
        assert crowd._retarget(0) and int(crowd.target[0]) != len(st.ids)
        crowd.pos[0] = st.stand[int(crowd.target[0])]


def _in_person_colour(rgb: np.ndarray) -> np.ndarray:
    """Which pixels of an (H, W, 3) picture are the maps' person colour (within 8 levels)."""
    from matplotlib.colors import to_rgb

    from biovln_ms.scene.topdown import PERSON_COLOR

    want = np.round(np.array(to_rgb(PERSON_COLOR)) * 255)
    return np.abs(rgb.astype(int) - want).max(axis=-1) <= 8


def test_dataset_show_draws_a_busy_episodes_people_and_their_paths(dataset, tmp_path):
    from PIL import Image
    from typer.testing import CliRunner

    from biovln_ms.cli import app
    from biovln_ms.scene.rules import scene_navigation
    from biovln_ms.scene.topdown import save_map

    def person_pixels(png) -> int:
        return int(_in_person_colour(np.asarray(Image.open(png).convert("RGB"))).sum())

    shown = tmp_path / "shown.png"
    r = CliRunner().invoke(app, ["dataset", "show", str(dataset), "--split", "busy_val", "-o", str(shown)])
    assert r.exit_code == 0, r.output
    ds = EpisodeDataset(dataset)
    ep = next(iter(ds.episodes("busy_val")))
    spec = ds.spec(ep["scene_id"])
    bare = save_map(spec, tmp_path / "bare.png", episode=ep, nav=scene_navigation(spec))  # no people given
    assert person_pixels(shown) > 300 and person_pixels(bare) == 0  # bodies and paths in the people's colour


@pytest.mark.render
def test_record_draws_the_people_and_their_recent_ways_on_the_map(dataset, tmp_path, monkeypatch):
    import biovln_ms.render.video as video
    from biovln_ms.episode_video import record_episode

    written = []
    monkeypatch.setattr(video, "write_mp4", lambda frames, out, fps: written.extend(frames))  # uncompressed
    out = record_episode(
        tmp_path / "ep.mp4", "busy_val", 0, "oracle", str(dataset), BUSY_ENV, size=(160, 120), gaps=True
    )
    maps = [_in_person_colour(f[:, 160:]) for f in written]  # the map: the frame's right half
    assert len(maps) == len(out["gaps"]) > 5
    assert all(m.sum() > 10 for m in maps)  # every frame shows the people
    assert any((a != b).any() for a, b in zip(maps, maps[1:]))  # and they move
