"""Lab dressing: non-goal objects placed by the generator on request, under the zone rules,
real obstacles in the navigation geometry and the episodes; off by default."""

import json

import numpy as np
import pytest

from biovln_ms.catalog import load_catalog
from biovln_ms.errors import CatalogError
from biovln_ms.scene.generator import generate_scene
from biovln_ms.scene.rules import check_layout, scene_free_space
from biovln_ms.scene.loading import parse_spec
from biovln_ms.scene.rules import validate_spec
from biovln_ms.scene.spec import SceneSpecError

SCENES = [("single_room", 150), ("two_room", 0), ("suite", 402), ("open_plan", 452), ("molecular_biology", 3)]
OBSTACLES = {"lab_stool", "lab_trolley", "shelving_unit", "lab_sink"}


@pytest.fixture(scope="module")
def dressed():
    return {t: generate_scene(t, seed, dressing=True) for t, seed in SCENES}


def test_dressing_is_off_by_default():
    s = generate_scene("single_room", 150)
    assert s.dressing == [] and s.name == "lab_s150_v0"
    assert "dressing" not in json.loads(s.to_json())  # undressed specs keep their bytes
    assert not {o.category for o in s.objects()} & {a.name for a in load_catalog().dressing()}


def test_dressed_scenes_keep_the_instruments_and_pass_every_rule(dressed):
    for t, seed in SCENES:
        d, plain = dressed[t], generate_scene(t, seed)
        assert d.name == plain.name + "_dressed" and d.dressing
        assert [o.model_dump() for o in d.instruments] == [o.model_dump() for o in plain.instruments]
        assert [o.model_dump() for o in d.furniture] == [o.model_dump() for o in plain.furniture]
        assert (
            validate_spec(parse_spec(json.loads(d.to_json()))).to_json() == d.to_json()
        )  # schema, catalog and layout rules
        assert generate_scene(t, seed, dressing=True).to_json() == d.to_json()  # same seed, same bytes
    cats = {o.category for d in dressed.values() for o in d.dressing}
    assert cats == {a.name for a in load_catalog().dressing()}


def test_no_dressing_in_any_goals_zone_2_or_3(dressed):
    for d in dressed.values():
        for o in d.dressing:
            body = o.placed().zone1()
            for g in d.goal_objects():
                if g.id == o.support:  # a tray on a goal bench
                    continue
                zones = g.placed().zone2().union(g.placed().zone3())
                assert body.intersection(zones).area < 1e-6, (d.name, o.id, g.id)


def test_dressing_obstacles_are_in_the_navigation_geometry_and_the_episodes(dressed):
    from biovln_ms.episodes.generator import EpisodeSampler

    for t, seed in SCENES:
        d = dressed[t]
        free, plain = scene_free_space(d), scene_free_space(generate_scene(t, seed))
        assert free.area < plain.area - 0.5, d.name
        for o in d.dressing:
            if o.category in OBSTACLES:
                assert free.intersection(o.placed().zone1()).area < 1e-9, (d.name, o.id)
        obstacles = [o.placed().zone1() for o in d.dressing if o.category in OBSTACLES]
        for ep in EpisodeSampler(d).episodes(8, seed=1):
            start = np.asarray(ep["start_position"][:2])
            from shapely.geometry import Point

            assert min(b.distance(Point(start)) for b in obstacles) >= d.robot_radius, (
                d.name,
                ep["episode_id"],
            )


def test_a_dressing_piece_in_a_goals_zone_3_is_refused(dressed):
    d = dressed["single_room"]
    goal = next(o for o in d.instruments if o.placement == "wall")
    stool = next(o for o in d.dressing if o.category == "lab_stool")
    data = json.loads(d.to_json())
    row = next(r for r in data["dressing"] if r["id"] == stool.id)
    row["position"][:2] = list(goal.goal)
    with pytest.raises(SceneSpecError, match="rule: dressing clear of goals"):
        validate_spec(parse_spec(data))
    row["position"][2] = 0.5  # not resting on the floor
    with pytest.raises(SceneSpecError, match="Eq. 4"):
        validate_spec(parse_spec(data))


def test_dressing_must_be_in_the_dressing_list():
    s = json.loads(generate_scene("single_room", 150, dressing=True).to_json())
    s["furniture"].append(s["dressing"].pop())
    with pytest.raises(SceneSpecError, match="is lab dressing: it belongs in dressing"):
        validate_spec(parse_spec(s))


def test_dressing_holds_for_fetch():
    d = generate_scene("suite", 402, robot_radius=0.29, dressing=True)
    assert d.dressing and check_layout(d) == []


def test_catalog_refuses_malformed_dressing(tmp_path):
    obj = json.loads(load_catalog().source.read_text())
    del obj["dressing"][0]["mount"]
    p = tmp_path / "c.json"
    p.write_text(json.dumps(obj))
    with pytest.raises(CatalogError, match="lab dressing needs a mount"):
        load_catalog(p)
    obj = json.loads(load_catalog().source.read_text())
    obj["assets"][0]["mount"] = "wall"
    p.write_text(json.dumps(obj))
    with pytest.raises(CatalogError, match="only lab dressing"):
        load_catalog(p)


def test_dressing_is_no_lsat_or_protocol_name():
    cat = load_catalog()
    names = {a.name for a in cat.dressing()}
    assert not names & set(cat.names()) and not names & set(cat.goal_categories())
    assert not set(cat.phrases().values()) & names
    assert cat.get("lab_stool").mount == "floor" and "lab_stool" not in cat  # get() finds it, names() do not


def test_the_manifest_records_dressing(tmp_path):
    from biovln_ms.episodes.dataset import EpisodeDataset
    from biovln_ms.episodes.writer import SplitPlan, write_dataset

    plain, dressed = generate_scene("single_room", 150), generate_scene("single_room", 150, dressing=True)
    m = write_dataset(
        tmp_path / "ds",
        [SplitPlan("a", [(plain, 3, False)]), SplitPlan("b", [(dressed, 3, False)])],
        progress=False,
    )
    assert "dressing" not in m["splits"]["a"] and "dressing" not in m["scenes"][plain.name]
    assert m["splits"]["b"]["dressing"] is True and m["scenes"][dressed.name]["dressing"] is True
    ds = EpisodeDataset(tmp_path / "ds")
    assert ds.spec(dressed.name).dressing and len(list(ds.episodes("b"))) == 3
