import math

import numpy as np

from biovln_ms.baselines.frontier import FREE, OCCUPIED, UNKNOWN, OccupancyMap


def _camera(w=160, h=120, hfov=math.radians(79)):
    fx = (w / 2) / math.tan(hfov / 2)
    K = np.array([[fx, 0, w / 2], [0, fx, h / 2], [0, 0, 1.0]])
    # camera at (0, 0, 0.88) looking along +x (OpenCV axes: x right, y down, z forward)
    R = np.array([[0, -1, 0], [0, 0, -1], [1, 0, 0]], float)
    t = -R @ np.array([0.0, 0.0, 0.88])
    return K, np.hstack([R, t[:, None]]), w, h


def test_depth_of_a_wall_gives_free_floor_then_obstacles():
    K, E, w, h = _camera()
    depth = np.full((h, w), 3.0, np.float32)  # a fronto-parallel wall 3 m ahead
    m = OccupancyMap((0.0, 0.0), 0.05, 20.0)
    m.integrate(depth, K, E, stride=4)
    row = m.cell([0.0, 0.0])[0]
    line = [m.grid[row, m.cell([x, 0.0])[1]] for x in np.arange(0.2, 2.9, 0.1)]
    assert all(v == FREE for v in line)
    assert m.grid[row, m.cell([3.0, 0.0])[1]] == OCCUPIED
    assert m.grid[row, m.cell([4.0, 0.0])[1]] == UNKNOWN  # behind the wall
    assert m.grid[m.cell([0.0, -2.5])[0], m.cell([0.0, -2.5])[1]] == UNKNOWN  # outside the field of view


def test_frontier_reaches_goals_in_the_env():
    import gymnasium as gym

    import biovln_ms  # noqa: F401
    from biovln_ms.baselines.frontier import FrontierPolicy

    env = gym.make(
        "BioVLN-OpFace-v0",
        obs_mode="rgbd",
        camera_width=320,
        camera_height=240,
        sim_backend="physx_cpu",
        render_backend="cpu",
    )
    pol = FrontierPolicy()
    wins = 0
    for k in range(3):
        obs, info = env.reset(seed=k)
        pol.reset(env.unwrapped.episode_info())
        for _ in range(500):
            obs, _, term, trunc, info = env.step(pol.act(obs, info))
            if bool(term) or bool(trunc):
                break
        wins += bool(info["success"])
        assert (pol.map.grid == FREE).sum() > 100 and (pol.map.grid == OCCUPIED).sum() > 20
    env.close()
    assert wins >= 2
