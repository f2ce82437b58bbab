import subprocess
import sys

import numpy as np
import trimesh

from biovln_ms.scene.export_glb import _chunks, export_scene_glb, semantic_colors
from biovln_ms.scene.generator import generate_scene
from biovln_ms.scene.spec import save_spec


def test_export_has_a_node_per_object_with_extras_and_semantic_colours(tmp_path):
    spec = generate_scene("two_room", 4)
    path = export_scene_glb(spec, tmp_path / "lab.glb")
    gltf, binary = _chunks(path.read_bytes())
    nodes = {n.get("name"): n for n in gltf["nodes"]}
    colors = semantic_colors()
    for o in spec.objects():
        assert o.id in nodes, o.id
        extras = nodes[o.id]["extras"]
        assert extras["category"] == o.category and extras["object_id"] == o.id
        if o.is_goal:
            assert np.allclose(extras["goal"], o.goal)
    assert "room_shell" in nodes and "ceiling" in nodes
    # every primitive has COLOR_0 = its owner's category colour
    owner = {}
    for n in gltf["nodes"]:
        if "mesh" in n:
            head = n["name"].split("/", 1)[0]
            owner[n["mesh"]] = spec.get(head).category if head not in ("room_shell", "ceiling") else "room"
    for mi, mesh in enumerate(gltf["meshes"]):
        for prim in mesh["primitives"]:
            acc = gltf["accessors"][prim["attributes"]["COLOR_0"]]
            view = gltf["bufferViews"][acc["bufferView"]]
            assert acc["count"] == gltf["accessors"][prim["attributes"]["POSITION"]]["count"]
            rgba = np.frombuffer(bytes(binary[view["byteOffset"] : view["byteOffset"] + 4]), np.uint8)
            assert tuple(rgba) == colors[owner[mi]]
    scene = trimesh.load(path, force="scene")  # the file re-opens
    lo, hi = scene.bounds
    assert lo[0] < 0 and hi[0] > 11.5 and hi[1] > 3.0  # glTF is Y-up: the walls' height is along +Y


def test_cli_export(tmp_path):
    spec_path = save_spec(generate_scene("single_room", 3), tmp_path / "s.json")
    out = tmp_path / "lab.glb"
    r = subprocess.run(
        [sys.executable, "-m", "biovln_ms.cli", "scene", "export", str(spec_path), "-o", str(out)],
        capture_output=True,
        text=True,
    )
    assert r.returncode == 0, r.stderr
    assert out.read_bytes()[:4] == b"glTF"
