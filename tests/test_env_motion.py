"""The motion bound holds for every allowed step: from random starts near walls, doors and instruments,
with random headings, the largest allowed FORWARD (and continuous moves) never ends the body more than
``ALLOWANCE`` (the robots guide's 8 cm) into an obstacle, on either robot; the bound is the moving
robot's own footprint, and a robot is not run on scenes made for another footprint."""

from __future__ import annotations

import math
import os

import gymnasium as gym
import numpy as np
import pytest
import shapely
from shapely.geometry import Point

import biovln_ms  # noqa: F401
from biovln_ms.agents.robots.locomotion import MAX_FORWARD_STEP, swept_motion
from biovln_ms.errors import BioVLNError
from biovln_ms.geometry.motion import ALLOWANCE
from biovln_ms.robot_specs import ROBOTS
from biovln_ms.scene.generator import generate_scene
from biovln_ms.scene.rules import floor_polygon
from biovln_ms.sim.footprints import collision_footprints

CPU = dict(sim_backend="physx_cpu", render_backend="cpu")
#: random starts per robot and control mode (each followed by two moves)
STARTS = int(os.environ.get("BIOVLN_MOTION_STARTS", 150))


def _obstacles(spec):
    """Everything the body may not enter: the outside of the floor and every collision footprint."""
    floor = floor_polygon(spec)
    minx, miny, maxx, maxy = floor.bounds
    outside = shapely.box(minx - 5, miny - 5, maxx + 5, maxy + 5).difference(floor)
    return shapely.union_all([outside, *collision_footprints(spec)])


@pytest.mark.parametrize("robot", list(ROBOTS))
@pytest.mark.parametrize("mode", ["discrete", "continuous"])
def test_the_largest_step_keeps_the_body_within_the_allowance(robot, mode):
    e = gym.make(
        "BioVLN-OpFace-v0",
        template="two_room",  # thin walls between the rooms and the corridor, doors, instruments
        robot_uids=robot,
        control_mode=mode,
        forward_step=MAX_FORWARD_STEP,
        obs_mode="none",
        **CPU,
    )
    try:
        u = e.unwrapped
        e.reset(seed=0)
        radius = ROBOTS[robot].footprint_radius
        core = _obstacles(u.scene_spec)
        free = floor_polygon(u.scene_spec).difference(core.buffer(radius - ALLOWANCE))
        near = free.intersection(core.buffer(radius + 0.6))  # legal starts within 0.6 m of contact
        rng = np.random.default_rng(7)
        minx, miny, maxx, maxy = near.bounds
        worst = 0.0
        for k in range(STARTS):
            if k % 100 == 0:
                e.reset(seed=0)  # the episode never reaches its step limit
            x, y = rng.uniform(minx, maxx), rng.uniform(miny, maxy)
            while not near.contains(Point(x, y)):
                x, y = rng.uniform(minx, maxx), rng.uniform(miny, maxy)
            u.agent.controller.put_back([0], np.array([[x, y, rng.uniform(-math.pi, math.pi)]]))
            for _ in range(2):
                e.step(1 if mode == "discrete" else np.array([1.0, rng.uniform(-1, 1), -1.0]))
                px, py = u.agent.controller.planar_pose()[0, :2]
                depth = radius - core.distance(Point(px, py)) if not core.contains(Point(px, py)) else radius
                worst = max(worst, depth)
        assert worst <= ALLOWANCE + 1e-3, (robot, mode, worst)
        assert worst > ALLOWANCE / 4, (robot, mode, worst)  # the starts do reach contact
    finally:
        e.close()


def test_the_swept_check_is_the_moving_robots():
    """The check's disc is the robot's: Fetch (0.29 m) with its centre 0.20 m from a wall has its body 9 cm
    inside, a crossing for Fetch and ordinary contact for the cylinder (0.20 m)."""
    spec = generate_scene("single_room", 0)
    x1 = floor_polygon(spec).bounds[2]
    start, end = (x1 - 0.6, 3.0), (x1 - 0.2, 3.0)  # toward the east wall, where no instrument stands
    assert (
        shapely.union_all(collision_footprints(spec)).distance(shapely.LineString([start, (x1, 3.0)])) > 0.5
    )
    assert swept_motion(spec, ROBOTS["fetch"].footprint_radius).crossed(*start, *end)
    assert not swept_motion(spec, ROBOTS["biovln_base"].footprint_radius).crossed(*start, *end)


def test_a_robot_on_scenes_made_for_another_footprint_is_refused():
    """Scenes made for the 0.20 m cylinder would let Fetch's body past the allowance at 1 m steps (and their
    free space and geodesics are the cylinder's); refused in one line before anything is built."""
    from biovln_ms.episodes.source import GeneratedEpisodes

    source = GeneratedEpisodes("single_room", 0, n=3)  # the cylinder's
    with pytest.raises(BioVLNError, match="field 'episodes'.*made for a 0.2 m footprint.*0.29 m"):
        gym.make("BioVLN-OpFace-v0", robot_uids="fetch", episodes=source, forward_step=1.0, **CPU)
    e = gym.make("BioVLN-OpFace-v0", episodes=source, obs_mode="none", **CPU)  # the cylinder runs them
    e.close()
