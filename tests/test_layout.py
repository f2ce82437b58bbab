"""LLM-assisted layout design: the structured request, our solver, and the LLM front end on loopback."""

import json
import subprocess
import sys

import pytest

from biovln_ms.llm.client import JSONChatClient, LLMConfig
from biovln_ms.lsat.layout import LayoutError, load_request, parse_request, solve_layout, suggest_request
from biovln_ms.scene.rules import check_consistency, check_layout, validate_spec
from biovln_ms.scene.loading import parse_spec

REQUEST = {
    "name": "cell_culture",
    "room": {"width": 7.0, "depth": 6.0},
    "instruments": [
        {"category": "incubator", "count": 2},
        {"category": "biosafety_cabinet", "wall": "S"},
        {"category": "centrifuge"},
        {"category": "waste_bin"},
    ],
}


def test_solver_output_passes_every_generator_rule():
    spec, notes = solve_layout(parse_request(REQUEST))
    cats = sorted(o.category for o in spec.instruments)
    assert cats == ["biosafety_cabinet", "centrifuge", "incubator", "incubator", "waste_bin"]
    assert not check_consistency(spec) and not check_layout(spec)
    assert any("lab table" in n for n in notes)  # the centrifuge needed a support
    bsc = next(o for o in spec.instruments if o.category == "biosafety_cabinet")
    assert bsc.position[1] < 1.0 and bsc.face[1] > 0.99  # on the south wall, facing in
    again, _ = solve_layout(parse_request(REQUEST))
    assert again.to_json() == spec.to_json()  # deterministic


@pytest.mark.parametrize(
    "bad, field",
    [
        ({**REQUEST, "instruments": [{"category": "spectrometer"}]}, "instruments[0].category"),
        ({**REQUEST, "instruments": [{"category": "lab_bench"}]}, "instruments[0].category"),
        ({**REQUEST, "room": {"width": 100, "depth": 6}}, "room.width"),
        ({**REQUEST, "exec": "import os"}, "exec"),
    ],
)
def test_bad_requests_name_the_field(bad, field):
    with pytest.raises(LayoutError) as e:
        parse_request(bad)
    assert e.value.field == field


def test_impossible_requests_say_so():
    with pytest.raises(LayoutError, match="cannot be laid out"):
        solve_layout(
            parse_request(
                {"room": {"width": 3.0, "depth": 3.0}, "instruments": [{"category": "incubator", "count": 4}]}
            )
        )
    with pytest.raises(LayoutError, match="lab bench is"):
        solve_layout(
            parse_request(
                {
                    "room": {"width": 5, "depth": 4},
                    "furniture": {"lab_bench": 1},
                    "instruments": [{"category": "centrifuge"}],
                }
            )
        )


def test_yaml_request_and_solve_cli(tmp_path):
    (tmp_path / "req.yaml").write_text(
        "room: {width: 8, depth: 6}\ninstruments:\n  - {category: refrigerator, wall: N}\n"
        "  - {category: mini_centrifuge}\n"
    )
    assert load_request(tmp_path / "req.yaml").instruments[0].wall == "N"
    (tmp_path / "evil.yaml").write_text("!!python/object/apply:os.system ['echo hi']\n")
    with pytest.raises(LayoutError, match="not valid YAML"):
        load_request(tmp_path / "evil.yaml")  # safe_load: tags that would run code are refused
    r = subprocess.run(
        [
            sys.executable,
            "-m",
            "biovln_ms.cli",
            "layout",
            "solve",
            str(tmp_path / "req.yaml"),
            "-o",
            str(tmp_path / "lab.json"),
            "--map",
            str(tmp_path / "lab.png"),
        ],
        capture_output=True,
        text=True,
    )
    assert r.returncode == 0, r.stderr
    validate_spec(parse_spec(json.loads((tmp_path / "lab.json").read_text())))
    assert (tmp_path / "lab.png").read_bytes()[:4] == b"\x89PNG"


@pytest.fixture
def llm(openai_server):
    """The shared loopback endpoint, answering from ``llm.answers`` in order."""
    openai_server.answers = []
    openai_server.reply = lambda body: openai_server.answers.pop(0)
    return openai_server


def _client(srv):
    return JSONChatClient(
        LLMConfig(f"http://127.0.0.1:{srv.server_address[1]}/v1", "deepseek-chat", "sk-test", 2.0, 0)
    )


def test_suggest_turns_a_description_into_a_valid_spec(llm):
    llm.answers = [json.dumps(REQUEST)]
    req = suggest_request(
        "a cell-culture room with two incubators, a biosafety cabinet and a centrifuge", _client(llm)
    )
    system = llm.requests[0]["body"]["messages"][0]["content"]
    assert "incubator (wall)" in system and "centrifuge (table_top)" in system  # the catalog is in the prompt
    spec, _ = solve_layout(req)
    assert not check_layout(spec)


def test_suggest_refuses_invalid_or_code_answers(llm):
    llm.answers = [
        json.dumps({**REQUEST, "instruments": [{"category": "__import__('os').system('rm -rf /')"}]})
    ]
    with pytest.raises(LayoutError, match="no valid layout request: .*unknown category"):
        suggest_request("a lab", _client(llm))
    llm.answers = ["Sure! Here is a lab: two incubators."]
    with pytest.raises(LayoutError, match="no valid layout request"):
        suggest_request("another lab", _client(llm))
