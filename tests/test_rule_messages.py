"""Rule messages name the object and where it is: a goal pushed into a wall, an instrument outside the
floor and two overlapping Zones 2 are told with the object's id and x, y (and the goal's)."""

import pytest

from biovln_ms.scene.generator import generate_scene
from biovln_ms.scene.rules import check_layout, validate_spec
from biovln_ms.scene.spec import SceneSpecError


@pytest.fixture(scope="module")
def lab():
    return generate_scene("single_room", seed=150)


def _moved(spec, obj_id: str, **update):
    objs = [o.model_copy(update=update) if o.id == obj_id else o for o in spec.instruments]
    return spec.model_copy(update={"instruments": objs})


def test_a_goal_pushed_into_a_wall_is_told_with_its_coordinates(lab):
    spec = _moved(lab, "refrigerator_0", goal=(7.175385, 0.05), goal_source="marker")
    (v,) = [v for v in check_layout(spec) if v.rule == "goal navigable"]
    assert v.message.startswith(
        "goal (7.18, 0.05) of 'refrigerator_0' at (7.18, 0.46) is not on navigable floor"
    )
    with pytest.raises(
        SceneSpecError, match=r"goal \(7\.18, 0\.05\) of 'refrigerator_0' at \(7\.18, 0\.46\)"
    ):
        validate_spec(spec, "lab.json")


def test_misplaced_objects_are_told_with_their_coordinates(lab):
    spec = _moved(lab, "waste_bin_0", position=(8.6, 3.2, 0.255))
    messages = {v.rule: v.message for v in check_layout(spec)}
    assert messages["inside rooms"] == "'waste_bin_0' at (8.60, 3.20) is not inside the rooms' floor"
    spec = _moved(lab, "waste_bin_0", position=(7.0, 1.2, 0.255))
    zone2 = [v.message for v in check_layout(spec) if v.rule == "Zone 2 disjoint (Eq. 2)"]
    assert "Zone 2 of 'refrigerator_0' at (7.18, 0.46) and 'waste_bin_0' at (7.00, 1.20) overlap" in zone2
