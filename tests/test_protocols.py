"""The protocol library: shipped workflows, order semantics, user folders, bad files."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest

from biovln_ms.catalog import load_catalog
from biovln_ms.protocols import (
    MAX_VISITS,
    MIN_VISITS,
    PROTOCOL_DIR,
    ProtocolError,
    load_protocol_file,
    load_protocols,
    parse_protocol,
)

SHIPPED = sorted(PROTOCOL_DIR.glob("*.json"))


def _proto(**over) -> dict:
    base = {
        "id": "my_protocol",
        "name": "My protocol",
        "description": "Two visits.",
        "steps": [
            {"category": "refrigerator", "purpose": "take the samples out"},
            {"category": "centrifuge", "purpose": "spin them"},
        ],
    }
    return {**base, **over}


def _write(folder: Path, name: str, obj) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / name
    path.write_text(obj if isinstance(obj, str) else json.dumps(obj))
    return path


@pytest.fixture(autouse=True)
def _no_env(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv("BIOVLN_PROTOCOL_PATH", raising=False)


# --- the shipped library -------------------------------------------------------------------------
def test_at_least_eight_shipped_protocols_load_in_id_order() -> None:
    lib = load_protocols()
    assert len(SHIPPED) >= 8 and len(lib) == len(SHIPPED)
    assert lib.ids() == sorted(lib.ids())
    assert [p.id for p in load_protocols()] == lib.ids()  # deterministic


@pytest.mark.parametrize("path", SHIPPED, ids=lambda p: p.stem)
def test_shipped_protocol_is_valid(path: Path) -> None:
    p = load_protocol_file(path)
    assert p.id == path.stem
    assert MIN_VISITS <= p.k <= MAX_VISITS
    goals = set(load_catalog().goal_categories())
    assert set(p.categories()) <= goals
    for v in p.visits():
        assert v.purpose and "\n" not in v.purpose
    assert p.description
    # every expanded order is admitted, and the file order is one of them
    orders = p.orders()
    assert len(orders) == len(set(orders))
    assert all(p.admits(o) for o in orders)
    assert p.admits([v.category for v in p.visits()])


def test_shipped_library_covers_groups_and_goal_categories() -> None:
    lib = load_protocols()
    with_groups = [p.id for p in lib if any(s.any_order for s in p.steps)]
    assert len(with_groups) >= 2
    assert {p.k for p in lib} >= {2, 3, 4, 5}
    assert set(lib.categories()) <= set(load_catalog().goal_categories())


# --- order semantics -----------------------------------------------------------------------------
def test_ordered_steps_must_come_in_order() -> None:
    p = load_protocols().get("cell_passage")
    assert p.admits(["incubator", "biosafety_cabinet", "centrifuge", "biosafety_cabinet", "incubator"])
    assert not p.admits(["biosafety_cabinet", "incubator", "centrifuge", "biosafety_cabinet", "incubator"])
    assert not p.admits(["incubator", "biosafety_cabinet", "centrifuge", "biosafety_cabinet"])  # short
    assert not p.admits([])
    assert len(p.orders()) == 1


def test_any_order_group_admits_every_permutation_and_nothing_else() -> None:
    p = parse_protocol(
        _proto(
            steps=[
                {"category": "refrigerator", "purpose": "a"},
                {
                    "any_order": [
                        {"category": "pipette", "purpose": "b"},
                        {"category": "cabinet", "purpose": "c"},
                        {"category": "lab_bench", "purpose": "d"},
                    ]
                },
                {"category": "waste_bin", "purpose": "e"},
            ]
        )
    )
    assert p.k == 5
    orders = [tuple(v.category for v in o) for o in p.orders()]
    assert len(orders) == 6 and len(set(orders)) == 6
    assert all(o[0] == "refrigerator" and o[-1] == "waste_bin" for o in orders)
    assert p.admits(["refrigerator", "lab_bench", "pipette", "cabinet", "waste_bin"])
    # a group member may not leave its group, nor a step jump into it
    assert not p.admits(["pipette", "refrigerator", "cabinet", "lab_bench", "waste_bin"])
    assert not p.admits(["refrigerator", "pipette", "cabinet", "waste_bin", "lab_bench"])
    assert not p.admits(["refrigerator", "pipette", "pipette", "cabinet", "waste_bin"])
    # Visit objects are accepted as well as category names
    assert p.admits(p.orders()[3])


def test_sample_order_is_admissible_and_seeded() -> None:
    p = load_protocols().get("waste_disposal_round")
    draws = [p.sample_order(np.random.default_rng(s)) for s in range(30)]
    assert all(p.admits(d) for d in draws)
    assert len({tuple(v.category for v in d) for d in draws}) > 1
    assert p.sample_order(np.random.default_rng(7)) == p.sample_order(np.random.default_rng(7))


# --- user folders --------------------------------------------------------------------------------
def test_user_folder_adds_a_protocol(tmp_path: Path) -> None:
    _write(tmp_path / "mine", "gel.json", _proto(id="gel_run"))
    lib = load_protocols(extra_dirs=[tmp_path / "mine"])
    assert "gel_run" in lib and len(lib) == len(SHIPPED) + 1
    assert lib.source("gel_run") == tmp_path / "mine" / "gel.json"
    assert lib.get("gel_run").categories() == ("refrigerator", "centrifuge")


def test_environment_folder_adds_a_protocol(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    _write(tmp_path, "gel.json", _proto(id="gel_run"))
    monkeypatch.setenv("BIOVLN_PROTOCOL_PATH", str(tmp_path))
    assert "gel_run" in load_protocols()
    assert "gel_run" in load_protocols(extra_dirs=[tmp_path])  # the same folder twice is one folder
    assert "gel_run" not in load_protocols(env=False)


def test_unknown_protocol_id_suggests() -> None:
    with pytest.raises(ProtocolError, match=r"did you mean 'cell_passage'\?.*fix: use one of"):
        load_protocols().get("cell_pasage")


# --- bad files: one line naming the file, the field and the fix ----------------------------------
def _group(*cats: str) -> dict:
    return {"any_order": [{"category": c, "purpose": "x"} for c in cats]}


def _visits(*cats: str) -> list[dict]:
    return [{"category": c, "purpose": "x"} for c in cats]


BAD = {
    "unknown_category": (
        _proto(steps=[*_visits("refrigerator"), {"category": "fridge", "purpose": "x"}]),
        "steps[1].category",
        r"unknown category 'fridge'; did you mean 'refrigerator'\?",
    ),
    "non_goal_misspelt": (
        _proto(steps=_visits("refrigerator", "centrifug")),
        "steps[1].category",
        r"did you mean 'centrifuge'",
    ),
    "unknown_in_group": (
        _proto(steps=[*_visits("refrigerator"), _group("pipette", "spectrophotometer")]),
        "steps[1].any_order[1].category",
        r"unknown category 'spectrophotometer'",
    ),
    "empty_steps": (_proto(steps=[]), "steps", r"no steps"),
    "k_too_small": (_proto(steps=_visits("refrigerator")), "steps", r"1 visit \(K = 1\)"),
    "k_too_large": (
        _proto(
            steps=[
                *_visits("refrigerator", "centrifuge", "pipette"),
                _group("cabinet", "incubator", "lab_bench"),
            ]
        ),
        "steps",
        r"6 visits \(K = 6\)",
    ),
    "missing_purpose": (
        _proto(steps=[*_visits("refrigerator"), {"category": "pipette"}]),
        "steps[1].purpose",
        "missing",
    ),
    "two_line_purpose": (
        _proto(steps=[*_visits("refrigerator"), {"category": "pipette", "purpose": "a\nb"}]),
        "steps[1].purpose",
        "several lines",
    ),
    "misspelt_field": (
        _proto(steps=[*_visits("refrigerator"), {"category": "pipette", "purpse": "x"}]),
        "steps[1].purpse",
        "Extra inputs",
    ),
    "group_of_one": (
        _proto(steps=[*_visits("refrigerator"), _group("pipette")]),
        "steps[1].any_order",
        "at least 2",
    ),
    "group_repeats": (
        _proto(steps=[*_visits("refrigerator"), _group("pipette", "pipette")]),
        "steps[1].any_order",
        "appears twice",
    ),
    "group_and_visit": (
        _proto(steps=[*_visits("refrigerator"), {**_group("pipette", "cabinet"), "category": "pipette"}]),
        "steps[1].any_order",
        "cannot also have category",
    ),
    "same_twice_in_a_row": (
        _proto(steps=[*_visits("refrigerator"), _group("pipette", "centrifuge"), *_visits("centrifuge")]),
        "steps",
        "visits 'centrifuge' twice in a row",
    ),
    "bad_id": (_proto(id="My Protocol"), "id", "should match pattern"),
    "not_an_object": ([1, 2], "<root>", "valid dictionary"),
}


@pytest.mark.parametrize("case", BAD, ids=list(BAD))
def test_bad_protocol_file_is_one_line(case: str, tmp_path: Path) -> None:
    obj, field, message = BAD[case]
    path = _write(tmp_path, "bad.json", obj)
    with pytest.raises(ProtocolError) as info:
        load_protocol_file(path)
    text = str(info.value)
    assert "\n" not in text and "Traceback" not in text
    assert text.startswith(f"{path}: field '{field}': "), text
    assert "(fix: " in text, text
    assert re.search(message, text), text


def test_not_json_is_one_line(tmp_path: Path) -> None:
    _write(tmp_path, "broken.json", '{"id": "x",')
    with pytest.raises(
        ProtocolError, match=r"broken\.json: protocol is not valid JSON at line 1 column \d+: .*\(fix: "
    ) as info:
        load_protocols(extra_dirs=[tmp_path])
    assert "\n" not in str(info.value)


def test_duplicate_id_names_both_files(tmp_path: Path) -> None:
    first = _write(tmp_path / "a", "one.json", _proto(id="dup"))
    second = _write(tmp_path / "b", "two.json", _proto(id="dup"))
    with pytest.raises(ProtocolError) as info:
        load_protocols(extra_dirs=[tmp_path / "a", tmp_path / "b"])
    text = str(info.value)
    assert text.startswith(f"{second}: field 'id': id 'dup' is already defined by {first}")
    assert "fix: give this protocol another id" in text and "\n" not in text


def test_shipped_id_cannot_be_redefined(tmp_path: Path) -> None:
    _write(tmp_path, "mine.json", _proto(id="cell_passage"))
    with pytest.raises(ProtocolError, match=r"mine\.json: field 'id': id 'cell_passage' is already defined"):
        load_protocols(extra_dirs=[tmp_path])


def test_missing_folder_is_one_line(tmp_path: Path) -> None:
    with pytest.raises(ProtocolError, match=r"no such folder of protocols \(fix: "):
        load_protocols(extra_dirs=[tmp_path / "nowhere"])
