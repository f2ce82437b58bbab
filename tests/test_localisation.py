"""Localisation without GPS+compass (``biovln_ms.baselines.frontier.localisation``): the scan matcher on
synthetic maps (actuation errors, blocked moves, featureless walls, lookalikes), dead reckoning with the
drive's mean errors, blocked-move detection, the camera mount, the harness's drift measure, and the frontier
baseline in the env under the ``realistic`` preset, reading no odometry and no info."""

import math
from dataclasses import replace

import numpy as np
import pytest

from biovln_ms.baselines.frontier.occupancy import OCCUPIED, OccupancyMap
from biovln_ms.baselines.frontier.localisation import (
    Localiser,
    blocked_ahead,
    camera_mount,
    extrinsic_at,
    motion,
)
from biovln_ms.baselines.policy import FORWARD, STOP, TURN_LEFT, TURN_RIGHT, TaskSpec
from biovln_ms.eval.harness import pose_drift
from biovln_ms.noise import PRESETS

TASK = TaskSpec(
    forward_step=0.25,
    turn_deg=30.0,
    hfov_deg=79.0,
    max_episode_steps=500,
    goal_categories=("centrifuge",),
    control_mode="discrete",
    robot_radius=0.2,
)


def _segments_points(segments, spacing=0.02) -> np.ndarray:
    """Points every ``spacing`` m along the segments ((x0, y0), (x1, y1))."""
    out = []
    for (x0, y0), (x1, y1) in segments:
        n = max(2, int(math.hypot(x1 - x0, y1 - y0) / spacing))
        t = np.linspace(0.0, 1.0, n)[:, None]
        out.append(np.array([x0, y0]) + t * np.array([x1 - x0, y1 - y0]))
    return np.concatenate(out)


def _on_cell_centres(segments):
    """The segments moved by half a 0.05 m cell, onto the map's cell centres (the map's own quantisation
    is then no error)."""
    return [tuple((x + 0.025, y + 0.025) for x, y in seg) for seg in segments]


ROOM = [  # a 6 x 4 m room with a bench along its north wall and a cabinet
    ((-1.0, -2.0), (5.0, -2.0)),
    ((5.0, -2.0), (5.0, 2.0)),
    ((5.0, 2.0), (-1.0, 2.0)),
    ((-1.0, 2.0), (-1.0, -2.0)),
    ((1.0, 1.4), (2.5, 1.4)),
    ((2.5, 1.4), (2.5, 2.0)),
    ((3.6, -1.2), (4.2, -1.2)),
    ((3.6, -1.2), (3.6, -2.0)),
]
ROOM = _on_cell_centres(ROOM)


def _map(segments) -> OccupancyMap:
    m = OccupancyMap((0.0, 0.0), 0.05, 20.0)
    rc = m.cell(_segments_points(segments))
    m.grid[rc[:, 0], rc[:, 1]] = OCCUPIED
    m.lo, m.hi = rc.min(0), rc.max(0) + 1
    return m


def _scan(segments, pose, fov=math.radians(79), max_range=5.0) -> np.ndarray:
    """The structure within the field of view and range of a robot at ``pose``, in its base frame (no
    occlusion: enough for matching)."""
    pts = _segments_points(segments) - pose[:2]
    c, s = math.cos(pose[2]), math.sin(pose[2])
    local = np.stack([c * pts[:, 0] + s * pts[:, 1], -s * pts[:, 0] + c * pts[:, 1]], 1)
    bearing = np.arctan2(local[:, 1], local[:, 0])
    keep = (np.abs(bearing) < fov / 2) & (np.linalg.norm(local, axis=1) < max_range)
    return local[keep]


REALISTIC = replace(TASK, noise=PRESETS["realistic"])


def _localiser_at(prediction) -> Localiser:
    loc = Localiser()
    loc.reset(prediction)
    return loc


def _after(action, prediction, task=REALISTIC) -> Localiser:
    """A localiser whose dead reckoning of ``action`` under ``task`` has just predicted ``prediction``."""
    forward = task.forward_step if action == FORWARD else 0.0
    turn = {TURN_LEFT: 1, TURN_RIGHT: -1}.get(action, 0) * math.radians(task.turn_deg)
    mean, _ = motion(forward, turn, task.noise.actuation)
    yaw = prediction[2] - mean[2]
    c, s = math.cos(yaw), math.sin(yaw)
    start = (prediction[0] - c * mean[0] + s * mean[1], prediction[1] - s * mean[0] - c * mean[1], yaw)
    loc = _localiser_at(start)
    assert np.allclose(loc.predict(action, task), prediction)
    return loc


def _offset(pose, along, across, dyaw_deg) -> np.ndarray:
    """``pose`` moved by ``along`` / ``across`` its heading and turned by ``dyaw_deg``."""
    c, s = math.cos(pose[2]), math.sin(pose[2])
    return np.asarray(pose, float) + [c * along - s * across, s * along + c * across, math.radians(dyaw_deg)]


@pytest.mark.parametrize("truth", [(1.0, 0.0, 0.3), (2.0, -0.5, -0.4), (0.5, 0.5, 1.2)])
@pytest.mark.parametrize("action", [FORWARD, TURN_LEFT])
def test_scan_matcher_recovers_the_actuation_error_of_a_move(truth, action):
    """The robot ended a move off what its command was expected to do, by about two standard deviations
    of the ``realistic`` actuation noise (across 0.15 m and 7 degrees after a FORWARD, 0.06 m and 6
    degrees after a turn); the scan finds it."""
    truth = np.array(truth)
    error = (0.05, -0.15, 7.0) if action == FORWARD else (0.02, 0.06, -6.0)
    loc = _after(action, _offset(truth, *error))
    pose = loc.correct(_scan(ROOM, truth), _map(ROOM))
    assert loc.accepted == 1
    assert np.linalg.norm(pose[:2] - truth[:2]) < 0.03
    assert abs(math.degrees(pose[2] - truth[2])) < 0.75


@pytest.mark.parametrize("blocked", [False, True])
def test_scan_matcher_recovers_a_blocked_forward_move(blocked):
    """Without sliding a blocked FORWARD leaves the robot where it was: a full step behind the moved
    prediction, unless the previous frame showed it blocked (then the prediction is the start)."""
    truth = np.array([4.3, 0.1, 0.0])  # facing the east wall
    loc = _localiser_at(truth)
    prediction = loc.predict(FORWARD, REALISTIC, blocked=blocked)
    assert np.linalg.norm(prediction[:2] - truth[:2]) == pytest.approx(0.0 if blocked else 0.26, abs=0.01)
    pose = loc.correct(_scan(ROOM, truth), _map(ROOM))
    assert np.linalg.norm(pose[:2] - truth[:2]) < 0.03


def test_scan_matcher_keeps_the_prediction_without_a_match():
    guess = np.array([1.0, 0.0, 0.3])
    empty = OccupancyMap((0.0, 0.0), 0.05, 20.0)
    loc = _localiser_at(guess)
    assert np.array_equal(loc.correct(_scan(ROOM, guess), empty), guess)  # nothing mapped yet
    assert np.array_equal(loc.correct(np.zeros((0, 2)), _map(ROOM)), guess)  # a featureless scan
    far = _scan(ROOM, guess) + [20.0, 0.0]  # a scan of something the map has never seen
    assert np.array_equal(loc.correct(far, _map(ROOM)), guess)
    assert (loc.accepted, loc.rejected) == (0, 3)


def test_scan_matcher_corrects_only_what_a_featureless_wall_constrains():
    """In front of one long straight wall the distance and heading are corrected; the position along the
    wall is not observable, so the prediction's is kept."""
    wall = _on_cell_centres([((5.0, -8.0), (5.0, 8.0))])
    truth = np.array([2.0, 0.0, 0.0])
    guess = truth + [0.1, 0.15, math.radians(4)]
    pose = _after(FORWARD, guess).correct(_scan(wall, truth), _map(wall))
    assert abs(pose[0] - truth[0]) < 0.03 and abs(pose[2] - truth[2]) < math.radians(0.75)
    assert abs(pose[1] - guess[1]) < 0.03


def test_scan_matcher_prefers_the_move_to_a_far_lookalike():
    """Between parallel walls every 0.3 m, seen end-on, the view is the same 0.3 m to either side: the
    move's prior keeps the pose the move explains (no jump across the window to a lookalike)."""
    walls = _on_cell_centres([((0.0, 0.3 * k), (8.0, 0.3 * k)) for k in range(-15, 16)])
    truth = np.array([1.0, 0.15, 0.0])
    loc = _after(TURN_LEFT, _offset(truth, 0.0, 0.03, 1.0))
    pose = loc.correct(_scan(walls, truth), _map(walls))
    assert loc.accepted == 1 and abs(pose[1] - truth[1]) < 0.05


def test_dead_reckoning_of_discrete_and_continuous_commands():
    loc = Localiser()
    loc.predict(FORWARD, TASK)
    loc.predict(TURN_LEFT, TASK)
    loc.predict(TURN_LEFT, TASK)
    loc.predict(TURN_LEFT, TASK)
    loc.predict(FORWARD, TASK)
    loc.predict(STOP, TASK)
    assert np.allclose(loc.pose, [0.25, 0.25, math.pi / 2])
    loc.predict(TURN_RIGHT, TASK)
    assert np.allclose(loc.pose[2], math.pi / 3)
    loc.reset()
    loc.predict(np.array([0.0, 0.5, -1.0]), TASK)  # half a step forward, then half a turn
    assert np.allclose(loc.pose, [0.125, 0.0, math.radians(15)])
    loc.predict(np.array([1.0, 1.0, 1.0]), TASK)  # STOP
    assert np.allclose(loc.pose, [0.125, 0.0, math.radians(15)])


def test_dead_reckoning_expects_the_drives_mean_errors():
    """Under actuation noise a move is expected to do what the drive does on average: a FORWARD
    overshoots and drifts left, a turn over-rotates either way (``biovln_ms.noise``, x0.5)."""
    loc = Localiser()
    assert np.allclose(loc.predict(FORWARD, REALISTIC), [0.25 + 0.0085, 0.021, 0.0155])
    loc.reset()
    assert np.allclose(loc.predict(TURN_RIGHT, REALISTIC), [0.0005, 0.0025, -math.radians(30) - 0.0215])
    loc.reset()
    assert np.allclose(loc.predict(STOP, REALISTIC), [0.0, 0.0, 0.0])
    mean, sd = motion(0.25, 0.0, 0.5)
    assert np.allclose(sd, 0.5 * np.sqrt([0.007, 0.023, 0.026]))


def test_blocked_ahead_from_the_scan_or_a_view_too_near_to_read():
    k = np.array([[388.0, 0.0, 320.0], [0.0, 388.0, 240.0], [0.0, 0.0, 1.0]])
    clear = np.full((480, 640), 3.0, np.float32)
    wall = np.stack([np.full(9, 0.40), np.linspace(-0.2, 0.2, 9)], 1)  # 0.4 m ahead, across the body
    aside = wall + [0.0, 0.5]  # beside the body's path
    assert blocked_ahead(wall, clear, k, TASK)
    assert not blocked_ahead(aside, clear, k, TASK)
    assert not blocked_ahead(wall[:2], clear, k, TASK)  # two stray points are no obstacle
    too_near = clear.copy()
    too_near[:, 100:540] = 0.0  # nearer than the sensor's minimum range: no reading
    assert blocked_ahead(np.zeros((0, 2)), too_near, k, TASK)


def test_camera_mount_keeps_height_and_tilt_and_drops_the_planar_pose():
    def extrinsic(x, y, yaw, z=0.88, tilt=0.1):
        fwd = np.array([math.cos(yaw) * math.cos(tilt), math.sin(yaw) * math.cos(tilt), -math.sin(tilt)])
        right = np.array([math.sin(yaw), -math.cos(yaw), 0.0])
        down = np.cross(fwd, right)
        c2w = np.eye(4)
        c2w[:3, :3] = np.stack([right, down, fwd], 1)
        c2w[:3, 3] = [x, y, z]
        return np.linalg.inv(c2w)[:3]

    mount = camera_mount(extrinsic(3.0, -2.0, 2.5))
    assert np.allclose(mount, camera_mount(extrinsic(-1.0, 4.0, -0.7)))  # the same wherever the robot is
    assert np.allclose(extrinsic_at((0.5, 1.0, 0.3), mount), extrinsic(0.5, 1.0, 0.3))


def test_pose_drift_puts_episode_frame_estimates_in_the_world():
    start = (2.0, 1.0, math.pi / 2)
    truth = [start, (2.0, 1.25, math.pi / 2), (2.0, 1.5, math.pi / 2)]
    # x along the start heading (world +y), y to its left (world -x): the last estimate is (1.6, 1.3)
    episode = {"pose_frame": "episode", "pose_estimates": [[0, 0, 0], [0.25, 0, 0], [0.3, 0.4, 0]]}
    assert pose_drift(episode, truth) == {"pose_drift": 0.4472, "pose_drift_max": 0.4472}
    world = {"pose_frame": "world", "pose_estimates": [list(start), [2.1, 1.25, 0]]}
    assert pose_drift(world, truth) == {"pose_drift": 0.1, "pose_drift_max": 0.1}
    assert pose_drift({}, truth) == {}


# --- the frontier baseline in the env without GPS+compass ---------------------------------------------
class Watched(dict):
    """A read-only view of an observation or info dict that logs the keys read (paths as "a/b")."""

    def __init__(self, d: dict, log: list, path: str = "") -> None:
        super().__init__(d)
        self.log, self.path = log, path

    def __getitem__(self, key):
        self.log.append(self.path + str(key))
        value = super().__getitem__(key)
        return Watched(value, self.log, f"{self.path}{key}/") if isinstance(value, dict) else value

    def get(self, key, default=None):
        return self[key] if key in self else default


def _episodes(dataset, scan_match: bool, noise="realistic"):
    """Run the frontier baseline on the split's episodes under ``noise``; per episode the harness's drift,
    success, and the keys the policy read."""
    import gymnasium as gym

    import biovln_ms  # noqa: F401
    from biovln_ms.baselines.frontier import FrontierParams, FrontierPolicy
    from biovln_ms.eval.rollout import rollout

    env = gym.make(
        "BioVLN-OpFace-v0",
        split="ms_val",
        dataset=dataset,
        obs_mode="rgbd",
        camera_width=320,
        camera_height=240,
        sim_backend="physx_cpu",
        render_backend="cpu",
        noise=noise,
    )
    pol = FrontierPolicy(FrontierParams(scan_match=scan_match))
    act = pol.act
    out = []
    try:
        for index in range(len(env.unwrapped.source.episodes)):
            obs_keys, info_keys, poses = [], [], []
            pol.act = lambda obs, info: act(Watched(obs, obs_keys), Watched(info, info_keys))
            for st in rollout(env, pol, index):
                poses.append([float(v) for v in st.info["agent_pose"][0]])
            stats = pol.episode_stats()
            turns = np.abs((np.diff([p[2] for p in poses]) + math.pi) % (2 * math.pi) - math.pi)
            out.append(
                {
                    **pose_drift(stats, poses),
                    "spun": bool((turns > math.pi / 2).any()),
                    "success": bool(st.info["success"]),
                    "obs_keys": set(obs_keys),
                    "extrinsics_read": obs_keys.count("sensor_param/head/extrinsic_cv"),
                    "info_keys": set(info_keys),
                    "frame": stats["pose_frame"],
                }
            )
    finally:
        env.close()
    return out


@pytest.fixture(scope="module")
def dataset(held_out_dataset):
    return held_out_dataset(ms_val=6)


@pytest.mark.slow
def test_frontier_without_gps_localises_by_scan_matching(dataset):
    corrected = _episodes(dataset, scan_match=True)
    dead_reckoning = _episodes(dataset, scan_match=False)
    for ep in corrected + dead_reckoning:
        assert ep["frame"] == "episode" and not ep["info_keys"]  # info (the simulator's pose) is never read
        assert not any(k.startswith("agent") for k in ep["obs_keys"])  # no odometry
        assert "extra/pointgoal" in ep["obs_keys"] and ep["extrinsics_read"] == 1  # the mount, once
    # no step turns the base by more than a command does (the yaw joint once spun at +-2 pi)
    assert not any(ep["spun"] for ep in corrected + dead_reckoning)
    pairs = list(zip(corrected, dead_reckoning))
    final = [np.mean([ep[i]["pose_drift"] for ep in pairs]) for i in (0, 1)]
    worst = [np.mean([ep[i]["pose_drift_max"] for ep in pairs]) for i in (0, 1)]
    wins = [sum(ep[i]["success"] for ep in pairs) for i in (0, 1)]
    print(
        f"{len(pairs)} episodes, mean pose drift (m) final / max: scan matching {final[0]:.3f} / "
        f"{worst[0]:.3f}, dead reckoning {final[1]:.3f} / {worst[1]:.3f}; SR {wins[0]} vs {wins[1]}"
    )
    assert final[0] < final[1] and worst[0] < worst[1]
    assert wins[0] > 0


def test_odometry_clearance_reads_the_nearest_mapped_obstacle():
    """``EpisodeOdometry.clearance`` (the RL state vector's clearance without GPS+compass): the nearest
    obstacle cell of its map, a cell with more evidence for than against counting under noisy depth,
    capped."""
    from biovln_ms.baselines.frontier.odometry import EpisodeOdometry

    odo = EpisodeOdometry(replace(TASK, noise=PRESETS["realistic"]))
    odo.map = OccupancyMap(np.zeros(2), 0.05, 20.0, evidence=True)
    assert odo.clearance((0.0, 0.0)) == 2.0  # nothing mapped: the cap
    odo.map.mark_occupied((3.0, 0.0))
    assert odo.clearance((0.0, 0.0)) == 2.0  # beyond the cap
    odo.map.mark_occupied((1.0, 0.0))
    assert abs(odo.clearance((0.0, 0.0)) - 1.0) <= 0.05
    r, c = odo.map.cell((0.0, 0.5))
    odo.map.log_odds[r, c] = 0.4  # one hit: not yet an obstacle for the planner, but for the clearance
    assert abs(odo.clearance((0.0, 0.0)) - 0.5) <= 0.05
    assert abs(odo.clearance((0.0, 1.0)) - 0.5) <= 0.05
