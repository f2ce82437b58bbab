"""The frontier baseline's units on synthetic inputs (no simulator): map, planner, controller, the
obs helpers, and the policy run from synthetic observation dicts."""

import math
from dataclasses import replace

import numpy as np
import pytest
import torch

from biovln_ms.baselines.frontier import (
    FREE,
    OCCUPIED,
    UNKNOWN,
    FrontierParams,
    FrontierPolicy,
    OccupancyMap,
    goal_from_sensor,
    pose_from_odometry,
)
from biovln_ms.baselines.frontier.control import FrontierController
from biovln_ms.baselines.frontier.planner import FrontierPlanner, Plan, PlanField, boxed_in, goal_if_reachable
from biovln_ms.baselines.policy import FORWARD, STOP, TURN_LEFT, TURN_RIGHT, EpisodeInfo, TaskSpec

W, H, HFOV, CAM_Z = 160, 120, math.radians(79), 0.88
TASK = TaskSpec(
    forward_step=0.25,
    turn_deg=30.0,
    hfov_deg=79.0,
    max_episode_steps=500,
    goal_categories=("centrifuge", "refrigerator"),
    control_mode="discrete",
    robot_radius=0.2,
)
PARAMS = FrontierParams(robot_radius=TASK.robot_radius)  # what FrontierPolicy.reset fills in from the task


# --- a level head camera looking at a wall, as ManiSkill's sensors would give it ---------------------
def _intrinsic() -> np.ndarray:
    fx = (W / 2) / math.tan(HFOV / 2)
    return np.array([[fx, 0, W / 2], [0, fx, H / 2], [0, 0, 1.0]])


def _cam2world_cv(x: float, y: float, yaw: float) -> np.ndarray:
    """4x4 camera-to-world pose in OpenCV axes (x right, y down, z forward) of a level camera."""
    forward = np.array([math.cos(yaw), math.sin(yaw), 0.0])
    right = np.array([math.sin(yaw), -math.cos(yaw), 0.0])
    m = np.eye(4)
    m[:3, :3] = np.stack([right, [0.0, 0.0, -1.0], forward], axis=1)
    m[:3, 3] = [x, y, CAM_Z]
    return m


def _extrinsic(pose) -> np.ndarray:
    return np.linalg.inv(_cam2world_cv(*pose))[:3]


def _cam2world_gl(pose) -> np.ndarray:
    return _cam2world_cv(*pose) @ np.diag([1.0, -1.0, -1.0, 1.0])  # OpenGL: y up, looking along -z


def _render(pose, wall_x: float) -> tuple[np.ndarray, np.ndarray]:
    """Depth (m) of a floor (z = 0) and a wall across the world at x = ``wall_x`` (0 where nothing is hit),
    and the mask of the pixels of a 0.6 m wide target on the wall, centred on y = 0."""
    v, u = np.mgrid[0:H, 0:W]
    K = _intrinsic()
    rays = np.stack([(u - K[0, 2]) / K[0, 0], (v - K[1, 2]) / K[1, 1], np.ones_like(u, float)], -1)
    d = rays @ _cam2world_cv(*pose)[:3, :3].T  # world direction per unit of depth
    with np.errstate(divide="ignore", invalid="ignore"):
        t_wall = np.where(d[..., 0] > 1e-9, (wall_x - pose[0]) / d[..., 0], np.inf)
        t_floor = np.where(d[..., 2] < -1e-9, -CAM_Z / d[..., 2], np.inf)
    z = np.minimum(t_wall, t_floor)
    wall_y = pose[1] + np.where(np.isfinite(t_wall), t_wall, 0.0) * d[..., 1]
    target = (t_wall < t_floor) & (np.abs(wall_y) < 0.3)
    return np.where(np.isfinite(z), z, 0.0), target


def _obs(pose, goal, wall_x: float) -> dict:
    """An observation dict shaped as in ``biovln_ms.baselines.policy`` (batch of one, torch tensors); the
    target on the wall is of the first goal category; ``goal`` None: no goal sensor."""
    depth, target = _render(pose, wall_x)
    depth_mm = np.clip(np.round(depth * 1000), 0, 32767).astype(np.int16)

    def t(a, dtype=torch.float32) -> torch.Tensor:
        return torch.as_tensor(np.asarray(a)[None], dtype=dtype)

    extra = {"semantic_category": t(target[..., None].astype(np.int16), torch.int16)}
    if goal is not None:
        d = np.asarray(goal) - np.asarray(pose[:2])
        phi = (math.atan2(d[1], d[0]) - pose[2] + math.pi) % (2 * math.pi) - math.pi
        extra["pointgoal_with_gps_compass"] = t([np.linalg.norm(d), phi])
    return {
        "agent": {"qpos": t(pose)},
        "extra": extra,
        "sensor_data": {
            "head": {"depth": t(depth_mm[..., None], torch.int16), "rgb": t(np.zeros((H, W, 3)), torch.uint8)}
        },
        "sensor_param": {
            "head": {
                "intrinsic_cv": t(_intrinsic()),
                "extrinsic_cv": t(_extrinsic(pose)),
                "cam2world_gl": t(_cam2world_gl(pose)),
            }
        },
    }


def _episode() -> EpisodeInfo:
    return EpisodeInfo("synthetic", 0, "centrifuge", TASK)


# --- obs helpers -------------------------------------------------------------------------------------
@pytest.mark.parametrize("pose", [(0.0, 0.0, 0.0), (1.5, -2.0, 2.5), (-3.0, 4.0, -math.pi / 2)])
def test_pose_is_the_odometry(pose):
    assert np.allclose(pose_from_odometry(_obs(pose, (5.0, 5.0), wall_x=pose[0] + 3.0)), pose, atol=1e-6)


def test_goal_from_sensor_is_exact():
    north = np.array([1.0, 2.0, math.pi / 2])
    assert np.allclose(goal_from_sensor(north, [2.0, math.pi / 2]), [-1.0, 2.0], atol=1e-12)
    pose, goal = np.array([0.5, -1.0, 2.0]), np.array([3.0, 1.5])
    d = goal - pose[:2]
    reading = [np.linalg.norm(d), math.atan2(d[1], d[0]) - pose[2]]
    assert np.allclose(goal_from_sensor(pose, reading), goal, atol=1e-12)


# --- occupancy map -------------------------------------------------------------------------------
def test_map_integrates_a_wall_in_front_of_a_level_camera():
    pose = (0.0, 0.0, 0.0)
    m = OccupancyMap((0.0, 0.0), 0.05, 20.0)
    scan = m.integrate(_render(pose, 3.0)[0].astype(np.float32), _intrinsic(), _extrinsic(pose), stride=4)
    row = m.cell([0.0, 0.0])[0]
    assert all(m.grid[row, m.cell([x, 0.0])[1]] == FREE for x in np.arange(0.2, 2.9, 0.1))
    assert m.grid[row, m.cell([3.0, 0.0])[1]] == OCCUPIED
    assert m.grid[row, m.cell([4.0, 0.0])[1]] == UNKNOWN  # behind the wall
    assert m.grid[tuple(m.cell([0.0, -2.5]))] == UNKNOWN  # outside the field of view
    assert np.allclose(scan.cam, [0.0, 0.0])
    assert scan.free_len[len(scan.free_len) // 2] == pytest.approx(2.95, abs=0.01)  # a cell short


# --- planner ---------------------------------------------------------------------------------------
def _grid(free: list, occupied: list, extent: float = 20.0) -> OccupancyMap:
    """A map of hand-made (row0, row1, col0, col1) cell boxes (centre cell (200, 200) at world 0, 0)."""
    m = OccupancyMap((0.0, 0.0), 0.05, extent)
    for value, boxes in ((FREE, free), (OCCUPIED, occupied)):
        for r0, r1, c0, c1 in boxes:
            m.grid[r0:r1, c0:c1] = value
    known = np.argwhere(m.grid != UNKNOWN)
    m.lo, m.hi = known.min(0), known.max(0) + 1
    return m


def _goal_rules(goal) -> FrontierPolicy:
    """The frontier baseline's target rules (its policy's methods) for a fixed goal."""
    rules = FrontierPolicy()
    rules.goal = np.asarray(goal, float)
    return rules


def _corridor() -> OccupancyMap:
    """A 1.5 m wide corridor (x from -1 to 3 m) open to the unknown at both ends: the west end 1 m
    from the robot at x = 0, the east end 3 m away."""
    return _grid(free=[(185, 215, 180, 260)], occupied=[(180, 185, 180, 260), (215, 220, 180, 260)])


def test_planner_goes_to_the_nearest_frontier_cluster():
    m = _corridor()
    planner = FrontierPlanner(PARAMS, _goal_rules([10.0, 0.0]))  # the goal far in the unknown
    field = PlanField.compute(m, np.zeros(2), PARAMS.inflate_cells)
    cands = planner.candidates(field)
    assert sorted(round(float(c.position[0])) for c in cands) == [-1, 3]  # one cluster per open end
    plan = planner.plan(m, np.zeros(3))
    assert plan.mode == "explore" and plan.target[0] < -0.9  # the west end, nearer by path
    assert np.allclose(plan.path[0], m.centre(m.cell([0.0, 0.0]))) and np.allclose(plan.path[-1], plan.target)
    planner.ban(plan.target)  # found unreachable: the other end is next
    assert planner.plan(m, np.zeros(3)).target[0] > 2.9


def test_planner_tiles_a_long_frontier_into_cluster_diameter_pieces():
    # a 6 m room, walled except its north side, which is open to the unknown along its whole length
    m = _grid(
        free=[(190, 210, 200, 320)],
        occupied=[(185, 190, 195, 325), (190, 210, 195, 200), (190, 210, 320, 325)],
    )
    field = PlanField.compute(m, m.centre([200, 260]), PARAMS.inflate_cells)
    cands = FrontierPlanner(PARAMS, _goal_rules([0, 0])).candidates(field)
    cands.sort(key=lambda c: c.position[0])
    # 120 frontier cells split at every 40th crop column (2 x 1.0 m cluster radius): 33 + 40 + 40 + 7,
    # the 7-cell remainder being below the 10-cell minimum
    assert [c.cells for c in cands] == [33, 40, 40]


def test_planner_goes_to_the_goal_once_its_cell_is_free_and_reachable():
    m = _grid(
        free=[(185, 215, 180, 260), (230, 251, 190, 211)],  # the corridor and a room north of it
        occupied=[(180, 185, 180, 260), (215, 220, 180, 260)],
    )
    walled_off = m.centre([240, 200])  # free and clear of obstacles, but beyond the unknown
    field = PlanField.compute(m, np.zeros(2), PARAMS.inflate_cells)
    assert goal_if_reachable(field, np.array([1.0, 0.0])) is not None
    assert goal_if_reachable(field, np.array([6.0, 0.0])) is None  # unknown
    assert goal_if_reachable(field, walled_off) is None  # not reachable
    plan = FrontierPlanner(PARAMS, _goal_rules([1.0, 0.0])).plan(m, np.zeros(3))
    assert plan.mode == "goal" and np.allclose(plan.target, [1.0, 0.0])
    assert np.allclose(plan.path[-1], m.centre(m.cell([1.0, 0.0])))


def test_without_sliding_a_boxed_in_robot_steps_clear_before_exploring_a_frontier_on_the_obstacle():
    """0.15 m from a wall whose face is still unknown in places (a noisy depth sensor's fringe): the escape
    growth lets the robot reach that fringe, a frontier it would drive into; with ``step_clear`` (the
    policy sets it without sliding) it first goes to the nearest cell clear of the full growth."""
    walls = [(180, 185, 180, 220), (215, 220, 180, 220), (185, 215, 180, 185), (185, 215, 203, 208)]
    m = _grid(free=[(185, 215, 185, 203)], occupied=walls)  # a closed room, east wall 0.15 m away
    m.grid[195:206, 201] = UNKNOWN  # the wall's unread fringe, beside the robot
    rules = _goal_rules([5.0, 0.0])
    plain = FrontierPlanner(PARAMS, rules).plan(m, np.zeros(3))
    assert plain.mode == "explore" and np.linalg.norm(plain.target) < 0.15  # the fringe, at the wall
    out = FrontierPlanner(replace(PARAMS, step_clear=True), rules).plan(m, np.zeros(3))
    assert out.mode == "explore" and not boxed_in(m, out.target, PARAMS.inflate_cells)
    assert out.target[0] < -0.05 and len(out.path) > 1  # away from the wall, along a path


def test_planner_falls_back_to_the_free_cell_nearest_the_goal_when_exhausted():
    walls = [(180, 185, 180, 220), (215, 220, 180, 220), (185, 215, 180, 185), (185, 215, 215, 220)]
    m = _grid(free=[(185, 215, 185, 215)], occupied=walls)  # a closed room
    goal = np.array([5.0, 0.3])
    planner = FrontierPlanner(PARAMS, _goal_rules(goal))
    field = PlanField.compute(m, np.zeros(2), PARAMS.inflate_cells)
    assert planner.candidates(field) == []
    plan = planner.plan(m, np.zeros(3))
    reach = field.reachable_centres()
    assert plan.mode == "goal"
    assert np.allclose(plan.target, reach[np.argmin(np.linalg.norm(reach - goal, axis=1))])
    assert plan.target[0] == pytest.approx(0.475) and plan.path  # the room's east side, 5 cells off the wall


# --- controller ------------------------------------------------------------------------------------
class FixedPlanner:
    """Hands out a fixed plan (a fresh copy of its path each time) and counts the calls."""

    def __init__(self, plan: Plan) -> None:
        self.fixed, self.calls, self.banned = plan, 0, []

    def plan(self, occ_map, pose) -> Plan:
        self.calls += 1
        return self.fixed._replace(path=list(self.fixed.path))

    def ban(self, target) -> None:
        self.banned.append(target)


def _controller(mode: str, target, path) -> tuple[FrontierController, FixedPlanner, OccupancyMap]:
    planner = FixedPlanner(Plan(mode, np.asarray(target, float), [np.asarray(p, float) for p in path]))
    m = OccupancyMap((0.0, 0.0), 0.05, 20.0)
    return FrontierController(PARAMS, 0.25, math.radians(30), m, planner), planner, m


@pytest.mark.parametrize(
    "bearing, action", [(40, TURN_LEFT), (-40, TURN_RIGHT), (14, FORWARD), (-14, FORWARD)]
)
def test_controller_turns_toward_a_waypoint_beyond_half_a_turn(bearing, action):
    wp = 2.0 * np.array([math.cos(math.radians(bearing)), math.sin(math.radians(bearing))])
    ctl, _, _ = _controller("explore", wp, [[0.0, 0.0], wp])
    assert ctl.act(np.zeros(3)) == action


def test_controller_stops_within_half_a_step_of_the_goal():
    ctl, _, _ = _controller("goal", [0.1, 0.0], [[0.0, 0.0], [0.1, 0.0]])
    assert ctl.act(np.array([1.0, -0.1, 0.0])) == TURN_LEFT  # the first waypoint is behind, to the left
    assert ctl.act(np.array([0.0, 0.05, math.pi])) == STOP  # facing away: the distance rule alone
    ctl, _, _ = _controller("goal", [2.0, 0.0], [[0.0, 0.0], [2.0, 0.0]])
    assert ctl.act(np.zeros(3)) == FORWARD


def test_controller_marks_an_obstacle_after_a_blocked_forward_move():
    ctl, planner, m = _controller("explore", [2.0, 0.0], [[0.0, 0.0], [1.0, 0.0], [2.0, 0.0]])
    assert ctl.act(np.zeros(3)) == FORWARD and planner.calls == 1 and (m.grid == OCCUPIED).sum() == 0
    ctl.act(np.zeros(3))  # the FORWARD did not move: blocked
    ahead = m.cell([PARAMS.robot_radius + m.res, 0.0])
    assert m.grid[ahead[0], ahead[1]] == OCCUPIED and (m.grid == OCCUPIED).sum() == 1
    assert planner.calls == 2  # re-planned at once
    ctl.act(np.array([0.25, 0.0, 0.0]))  # this FORWARD moved: no new obstacle
    assert (m.grid == OCCUPIED).sum() == 1


def test_controller_bans_an_unreachable_frontier_and_gives_up_after_stuck_turns():
    ctl, planner, _ = _controller("explore", [2.0, 0.0], [])
    actions = [ctl.act(np.zeros(3)) for _ in range(PARAMS.stuck_turns)]
    assert actions == [TURN_LEFT] * (PARAMS.stuck_turns - 1) + [STOP]
    assert len(planner.banned) == PARAMS.stuck_turns


# --- the policy from observations alone ----------------------------------------------------------
def _drive(policy, pose, goal, wall_x: float, steps: int = 60) -> tuple[list[int], np.ndarray]:
    """Run ``policy`` with ideal discrete motion in a world of a floor and one wall."""
    policy.reset(_episode())
    pose, actions = np.array(pose, float), []
    for _ in range(steps):
        a = policy.act(_obs(pose, goal, wall_x), {})
        actions.append(a)
        if a == STOP:
            break
        if a == FORWARD:
            pose[:2] += TASK.forward_step * np.array([math.cos(pose[2]), math.sin(pose[2])])
        else:
            pose[2] += math.radians(TASK.turn_deg) * (1 if a == TURN_LEFT else -1)
    return actions, pose


def test_frontier_policy_runs_from_synthetic_observations():
    pol = FrontierPolicy()
    goal = np.array([1.5, 1.0])
    actions, pose = _drive(pol, (0.0, 0.0, 0.0), goal, wall_x=3.0)
    assert actions[-1] == STOP and TURN_LEFT in actions and actions.count(FORWARD) >= 6
    assert np.linalg.norm(pose[:2] - goal) < TASK.forward_step
    assert np.allclose(pol.goal, goal, atol=1e-5)  # read from the float32 sensor at the first step
    assert (pol.map.grid == OCCUPIED).sum() > 20 and pol.control.plan.mode == "goal"


class ConstantScorer:
    name = "constant"

    def score(self, rgb, target) -> float:
        return 0.5


def test_vlfm_runs_from_synthetic_observations_without_the_goal_sensor():
    from biovln_ms.baselines.vlfm import VLFMPolicy

    pol = VLFMPolicy(detector="gt", scorer=ConstantScorer())  # the synthetic frames carry the segmentation
    actions, pose = _drive(pol, (0.0, 0.0, 0.0), None, wall_x=3.0)
    assert actions[-1] == STOP and pol.detections > 0 and pol.episode_stats()["object_seen"]
    assert 2.3 < pose[0] < 3.0 - PARAMS.robot_radius and abs(pose[1]) < 0.3  # before the target


def test_evidence_map_clears_a_lone_noisy_hit_and_keeps_a_wall():
    """With a noisy depth sensor the frontier map weighs evidence over frames: a cell hit once and then
    seen through becomes free, a cell hit in three frames is an obstacle, a cell hit twice is not yet."""
    from biovln_ms.baselines.frontier.occupancy import FREE, OCCUPIED, UNKNOWN, OccupancyMap

    m = OccupancyMap((0.0, 0.0), 0.05, 4.0, evidence=True)
    wall, ghost, none = m.cell((1.0, 0.0)), m.cell((0.5, 0.5)), np.zeros((0, 2), int)
    m._add_evidence(none, np.array([wall, ghost]))  # frame 1: both look like obstacles
    m._add_evidence(np.array([ghost]), np.array([wall]))  # frame 2: a ray passes through the ghost
    assert m.grid[tuple(ghost)] != OCCUPIED and m.grid[tuple(wall)] == UNKNOWN  # two hits: not yet
    m._add_evidence(np.array([ghost]), np.array([wall]))  # frame 3
    assert m.grid[tuple(wall)] == OCCUPIED
    m._add_evidence(np.array([ghost]), none)  # a third ray through the ghost
    assert m.grid[tuple(ghost)] == FREE
