"""An instrument is a catalog entry plus one builder module: a toy one, added from outside the package (a
catalog copy with one more entry named by ``$BIOVLN_CATALOG``, and a module registering its builder with
``@instrument``), gets its GLB from the asset generator, its colour on the top-down map and its words in
the protocol vocabulary, with no file of the package edited."""

from __future__ import annotations

import ast
import importlib.util
import json
import sys
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import pytest
from matplotlib.colors import to_rgb

from biovln_ms.assetgen import instruments
from biovln_ms.assetgen.generate import generate_assets, load_glb, plans
from biovln_ms.assetgen.instruments import BUILDERS, LIVE_DECALS, unregister
from biovln_ms.catalog import CATALOG_ENV, derived_map_color, load_catalog
from biovln_ms.paths import CATALOG_PATH
from biovln_ms.protocols.vocabulary import build_vocabulary, load_vocabulary, vocabulary_path
from biovln_ms.scene.generator import generate_scene
from biovln_ms.scene.topdown import category_color, draw_map

TOY = "sonicator"
TOY_ENTRY = {
    "name": TOY,
    "display_name": "Sonicator",
    "dimensions": [0.5, 0.4, 0.6],
    "placement": "floor",
    "face": "-Y",
    "d_half": 0.2,
    "approach_distance": 0.6,
    "success_radius": 0.8,
    "goal_category": True,
    "rationale": "A toy instrument of the plugin test (no map_color: the map derives one).",
}
TOY_MODULE = '''
from biovln_ms.assetgen import textures as tx
from biovln_ms.assetgen.instruments._kit import WHITE, DARK, instrument, live, paint


def toy_label(v):
    return tx.label(["SONICATOR", v.tag], WHITE, DARK, v.rng("label").integers(1 << 30), width=128, height=64)


@instrument("sonicator", live_decals={"label": toy_label})
def sonicator(k):
    k.box_span("body", (-k.W / 2, k.front, k.bottom), (k.W / 2, k.back, k.top), paint(k, "body", WHITE))
    live(k, "label", (0.0, k.front, k.bottom + 0.3), 0.2, 0.1)
'''


@pytest.fixture
def toy(tmp_path, monkeypatch):
    """The toy instrument: a catalog copy with its entry (made the default catalog) and its module."""
    obj = json.loads(CATALOG_PATH.read_text())
    obj["assets"].append(TOY_ENTRY)
    catalog_path = tmp_path / "catalog.json"
    catalog_path.write_text(json.dumps(obj))
    module_path = tmp_path / "toy_sonicator.py"
    module_path.write_text(TOY_MODULE)
    spec = importlib.util.spec_from_file_location("toy_sonicator", module_path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    monkeypatch.setenv(CATALOG_ENV, str(catalog_path))
    yield load_catalog()
    unregister(TOY)
    sys.modules.pop("toy_sonicator", None)


def test_the_toy_is_registered_and_generated(toy, tmp_path):
    assert (
        TOY in toy and toy.get(TOY).goal_category and TOY in BUILDERS and list(LIVE_DECALS[TOY]) == ["label"]
    )
    manifest = generate_assets(tmp_path / "assets", catalog=toy, names=[TOY], progress=False)
    assert list(manifest["files"]) == [f"{TOY}.glb"] and manifest["catalog_sha256"] == toy.sha256
    scene = load_glb(tmp_path / "assets" / f"{TOY}.glb")
    assert np.allclose(scene.bounds[1] - scene.bounds[0], TOY_ENTRY["dimensions"], atol=1e-6)
    assert any(
        f"{TOY}_decal_label" in str(getattr(g.visual, "material", None).name) for g in scene.geometry.values()
    )


def test_the_toy_shows_in_its_map_colour(toy):
    color = category_color(TOY)
    assert color == toy.get(TOY).color == derived_map_color(TOY) and toy.get(TOY).map_color is None
    assert color not in {category_color(c) for c in load_catalog(CATALOG_PATH).names()}
    spec = generate_scene("two_room", 200)
    i = next(i for i, o in enumerate(spec.instruments) if o.placement == "wall")
    objects = list(spec.instruments)
    objects[i] = objects[i].model_copy(update={"category": TOY})
    spec = spec.model_copy(update={"instruments": objects})
    fig, ax = plt.subplots(figsize=(9, 7))
    draw_map(spec, ax)
    fig.canvas.draw()
    pixels = np.asarray(fig.canvas.buffer_rgba())[..., :3].reshape(-1, 3)
    plt.close(fig)
    want = np.round(np.asarray(to_rgb(color)) * 255).astype(int)
    assert (np.abs(pixels.astype(int) - want).max(axis=1) == 0).sum() >= 20  # its goal star, drawn opaque


def test_the_vocabulary_knows_the_toy_and_keeps_its_ids(toy):
    shipped = json.loads(vocabulary_path().read_text())["tokens"]
    vocab = load_vocabulary()
    assert vocab.tokens[: len(shipped)] == tuple(shipped)  # the shipped ids do not move
    assert vocab.tokens[len(shipped) :] == (TOY,) and vocab.unknown("Go to the sonicator.") == []
    assert vocab == build_vocabulary()  # no new vocabulary file needed
    assert TOY in toy.goal_categories()


def test_the_packaged_vocabulary_is_its_file(monkeypatch):
    monkeypatch.delenv(CATALOG_ENV, raising=False)
    assert load_vocabulary().tokens == tuple(json.loads(vocabulary_path().read_text())["tokens"])


def test_every_catalog_name_has_a_builder_and_every_builder_a_name():
    catalog = load_catalog(CATALOG_PATH)
    assert set(BUILDERS) == {p.name for p in plans(catalog)}
    assert set(LIVE_DECALS) <= set(BUILDERS)
    assert all(catalog.get(a.name).map_color for a in catalog.assets())  # the shipped maps' colours are data


def test_the_shared_kit_imports_no_builder():
    kit = Path(instruments.__file__).with_name("_kit.py")
    imported = {
        n.module if isinstance(n, ast.ImportFrom) else a.name
        for n in ast.walk(ast.parse(kit.read_text()))
        if isinstance(n, (ast.Import, ast.ImportFrom))
        for a in n.names
    }
    assert not {m for m in imported if m and m.startswith(instruments.__name__)}
