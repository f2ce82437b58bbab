"""A person's body as the model knows it, and what the measures read of the people after a step (NumPy and
shapely only: evaluation reads the measures without the route planner)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import shapely

#: m: a person's body, a disc about their centre (the SAPIEN figure, shoulders 0.4 m wide, fits in it)
PERSON_RADIUS = 0.2
#: m: the figure's height
PERSON_HEIGHT = 1.7


def overlaps_zone(zone, centres) -> bool:
    """Whether the body of a person centred at any of ``centres`` ((P, 2)) overlaps ``zone`` (a shapely
    geometry, e.g. an instrument's Zone 3)."""
    return bool(len(centres)) and bool(
        (shapely.distance(zone, shapely.points(centres)) < PERSON_RADIUS).any()
    )


@dataclass
class PeopleStep:
    """The people of ``num_envs`` sub-envs after a step (or at reset), as the measures read them."""

    positions: np.ndarray  # (N, P, 2) float64 people's centres
    hit: np.ndarray  # (N,) bool: the robot's move this step was cut at a person's body
    people_wait: np.ndarray  # (N,) s: person-seconds people stood waiting for the robot this step
    robot_radius: float  # m, the robot's footprint
    seconds: float  # s, the step's duration

    def centre_distance(self, position: np.ndarray, idx) -> np.ndarray:
        """(n,) m from the robot's centre to the nearest person's body of rows ``idx`` (the clearance
        convention: the robot's radius not subtracted)."""
        d = self.positions[idx] - position[idx][:, None, :]
        return np.maximum(np.hypot(d[..., 0], d[..., 1]).min(axis=1) - PERSON_RADIUS, 0.0)

    def body_gap(self, centre: np.ndarray) -> np.ndarray:
        """(n,) m from the robot's body to the nearest person's body, from :meth:`centre_distance`'s output
        (0 at contact)."""
        return np.maximum(centre - self.robot_radius, 0.0)
