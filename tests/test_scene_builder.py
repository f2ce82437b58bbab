"""The spec built into ManiSkill/SAPIEN: one actor per object, named by id, own segmentation id."""

import gymnasium as gym
import numpy as np
import pytest

import biovln_ms.tasks.lab_scene_env  # noqa: F401
from biovln_ms.scene.generator import generate_scene
from biovln_ms.sim.maniskill_builder import LabSceneBuilder

pytestmark = pytest.mark.render


@pytest.fixture(scope="module")
def env_and_spec():
    spec = generate_scene("two_room", 2)
    env = gym.make(
        "BioVLN-LabScene-v0",
        specs=[spec],
        obs_mode="none",
        sim_backend="physx_cpu",
        render_backend="cpu",
        render_mode="rgb_array",
        render_size=(320, 240),
    )
    env.reset(seed=0)
    yield env.unwrapped, spec
    env.close()


def test_scene_builder_is_registered():
    from mani_skill.utils.scene_builder.registration import REGISTERED_SCENE_BUILDERS

    assert REGISTERED_SCENE_BUILDERS["BioVLN-Lab"].scene_builder_cls is LabSceneBuilder


def test_every_object_is_an_actor_named_by_id(env_and_spec):
    env, spec = env_and_spec
    built = env.scene_builder.built[0]
    assert set(built.objects) == {o.id for o in spec.objects()}
    for o in spec.objects():
        actor = built.objects[o.id]
        assert actor.name == o.id
        p = actor.pose.p.cpu().numpy()[0]
        assert np.allclose(p, o.position, atol=1e-5)


def test_segmentation_ids_are_unique_per_object(env_and_spec):
    env, spec = env_and_spec
    ids = env.scene_builder.segmentation_ids(0)
    assert sorted(ids.values()) == sorted(o.id for o in spec.objects())
    assert len(ids) == len(spec.objects())


def test_instruments_have_collision_shapes(env_and_spec):
    env, spec = env_and_spec
    for o in spec.objects():
        actor = env.scene_builder.built[0].objects[o.id]
        body = actor._objs[0].find_component_by_type(__import__("sapien").physx.PhysxRigidBaseComponent)
        shapes = body.collision_shapes
        assert len(shapes) >= 1, o.id  # SAPIEN silently skips shapes it cannot cook: make sure none were


def test_overview_render_shows_the_scene(env_and_spec):
    env, _ = env_and_spec
    img = env.render().cpu().numpy()[0]
    assert img.shape == (240, 320, 3)
    assert img.std() > 10


def test_rebuild_on_reconfigure(env_and_spec):
    env, spec = env_and_spec
    env.reset(seed=1, options={"reconfigure": True})
    assert set(env.scene_builder.built[0].objects) == {o.id for o in spec.objects()}


@pytest.mark.slow
def test_cli_render(tmp_path):
    import subprocess
    import sys

    out = tmp_path / "lab.json"
    png = tmp_path / "view.png"
    r = subprocess.run(
        [
            sys.executable,
            "-m",
            "biovln_ms.cli",
            "scene",
            "generate",
            "--seed",
            "5",
            "-o",
            str(out),
            "--render",
            str(png),
        ],
        capture_output=True,
        text=True,
    )
    assert r.returncode == 0, r.stderr
    from PIL import Image

    img = np.asarray(Image.open(png))
    assert img.shape[:2] == (720, 960) and img.std() > 10


def test_navigable_positions_cover_the_free_space():
    """ManiSkill's ``navigable_positions``: per sub-env a flat mesh whose area is the robot's free space."""
    import gymnasium as gym

    from biovln_ms.scene.rules import scene_free_space

    env = gym.make("BioVLN-OpFace-v0", obs_mode="none", sim_backend="physx_cpu", render_backend="cpu")
    try:
        env.reset(seed=0)
        u = env.unwrapped
        (mesh,) = u.scene_builder.navigable_positions
        free = scene_free_space(u.scene_spec)
        assert mesh.area == pytest.approx(free.area, rel=1e-6)
        assert np.allclose(mesh.vertices[:, 2], 0.0)
        pts = mesh.triangles_center[:, :2]
        import shapely

        assert shapely.contains_xy(free.buffer(1e-6), pts[:, 0], pts[:, 1]).all()
    finally:
        env.close()


@pytest.mark.parametrize("template,seed", [("suite", 400), ("open_plan", 450), ("two_room", 200)])
def test_walls_stand_outside_the_floor_and_a_doorway_is_as_wide_as_the_free_space_says(template, seed):
    """A wall box lengthened into a doorway (a concave corner) narrowed the door in the physics, not in the
    free space: the oracle got stuck at suite doors. Every wall box now lies outside the floor, and the
    convex corners stay closed (the room's outline is covered)."""
    from shapely.geometry import Polygon
    from shapely.ops import unary_union

    from biovln_ms.scene.shell import wall_spans

    spec = generate_scene(template, seed)
    floor = unary_union([Polygon(r.polygon) for r in spec.rooms])
    boxes = []
    for w, (a, b) in zip(spec.walls, wall_spans(spec)):
        n = np.asarray(w.interior)
        boxes.append(Polygon([a, b, b - n * w.thickness, a - n * w.thickness]))
        assert boxes[-1].intersection(floor).area < 1e-9, w.id
    ring = floor.buffer(0.1, join_style="mitre").difference(floor)
    assert ring.difference(unary_union(boxes)).area < 1e-6  # closed: no gap at any corner


def test_a_plain_sapien_view_then_an_env_share_one_render_device():
    """SAPIEN keeps one render device per process: the plain scenes behind goal views and detector
    frames name the device the envs use, so an env made after them still renders."""
    import subprocess
    import sys

    code = (
        "import gymnasium as gym, biovln_ms\n"
        "from biovln_ms.render.sapien_utils import new_scene\n"
        "new_scene()\n"
        "env = gym.make('BioVLN-OpFace-v0', obs_mode='none', sim_backend='physx_cpu', render_backend='cpu')\n"
        "env.reset(seed=0)\n"
        "env.close()\n"
        "print('both rendered')\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr[-2000:]
    assert "both rendered" in out.stdout
