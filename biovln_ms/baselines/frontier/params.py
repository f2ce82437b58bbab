"""The frontier baseline's parameters, shared by its map, planner and controller (paper Table 15)."""

from __future__ import annotations

import math
from dataclasses import dataclass

from biovln_ms.constants import FLOOR_HEIGHT


@dataclass(frozen=True)
class FrontierParams:
    """Frontier exploration parameters: paper Table 15 where marked, otherwise this implementation's."""

    # occupancy map
    resolution: float = 0.05  # m per grid cell (Table 15)
    extent: float = 100.0  # m, side of the square grid centred on the start
    depth_clip: float = 10.0  # m: farther depth is "nothing seen up to here" (Table 15)
    pixel_stride: int = 8  # image rows sampled every this many pixels (Table 15)
    floor_z: float = FLOOR_HEIGHT  # m: depth points higher than this ...
    top_z: float = 1.0  # m: ... and lower than this are obstacles (the robot is 0.95 m tall)
    forget: bool | None = None  # rays clear obstacle cells (what moves); None: with people (TaskSpec.people)
    # planner
    cluster_radius: float = 1.0  # m: frontier groups are split into tiles of this diameter (Table 15)
    min_frontier_cells: int = 10  # a smaller frontier tile is no candidate (Table 15)
    robot_radius: float | None = (
        None  # m: obstacles are grown by robot_radius + margin; None: the robot's (TaskSpec)
    )
    margin: float = 0.05  # m (Table 15)
    # m added to the margin on a map that forgets (people): depth sees a person's figure, which lies up to
    # this much inside the body the robot must not touch (biovln_ms.people.body.PERSON_RADIUS)
    people_margin: float = 0.1
    # m added to the people check's reach (frontier.control), not to the planner's growth, under actuation
    # noise: how far a FORWARD may land aside (frontier.sideways_spread; the robot knows its own noise)
    noise_margin: float = 0.0
    # controller
    replan_every: int = 4  # steps between re-plans (Table 15)
    waypoint_reach: float = 0.3  # m: a nearer waypoint is passed, a nearer exploration target re-planned
    blocked_move: float = 0.02  # m: a FORWARD that moved less was blocked by something the map missed
    step_clear: bool = False  # boxed in: first go to the nearest cell clear of the full growth (set by the
    # policy without sliding, where a move that grazes an obstacle is lost; frontier.planner)
    # on a map that forgets (people): consecutive waits for something in the way after which plans grow
    # obstacles by a disc, or a robot boxed in squeezes out (frontier.control): a standing person or a wall
    # the diamond growth let the path pass too near
    wait_limit: int = 8
    stuck_turns: int = 12  # consecutive steps without a path (turning left to look around) before STOP
    # localisation without GPS+compass (biovln_ms.baselines.frontier.localisation)
    scan_match: bool = True  # correct dead reckoning by matching each depth scan to the map (False: dead
    # reckoning alone, for comparison)

    @property
    def inflate_cells(self) -> int:
        """Cells by which obstacles are grown for planning: ceil((robot radius + margin) / resolution)."""
        if self.robot_radius is None:
            raise ValueError("robot_radius is not set: FrontierPolicy.reset takes it from the task")
        return math.ceil((self.robot_radius + self.margin) / self.resolution)
