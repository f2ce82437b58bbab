"""Noise presets: actuation noise, sensor noise, what the robot senses and whether it slides along walls.

The paper's setting is ideal (exact motion, perfect sensors, GPS+compass). ``realistic`` follows the
spirit of the Habitat PointNav 2020 challenge: LoCoBot actuation noise at half strength, Gaussian RGB
noise (sigma 0.1), structured-light depth noise (:mod:`biovln_ms.sensor_noise`), no GPS+compass and no
sliding along walls. Any combination is a :class:`NoiseConfig`; ``gym.make(..., noise="realistic")``,
``noise={"preset": "realistic", "actuation": 1.0}`` or ``noise=NoiseConfig(...)``.

Actuation noise (:class:`MotionNoise`): every FORWARD or turn adds errors along and across the heading and
in heading, each a Gaussian truncated at +-3 sigma, from the published LoCoBot figures for its
proportional controller (mean and variance per component); the along error takes the sign of the
commanded translation and the heading error the sign of the commanded rotation (zero counts as
positive), the across error is applied as sampled (to the robot's left). The multiplier scales the
errors. The noisy target goes to the physics, so walls still stop the robot.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields, replace
from typing import Any

from statistics import NormalDist

import numpy as np

from biovln_ms.errors import BioVLNError

TRUNCATION = 3.0  # sigmas
_NORMAL = NormalDist()  # the standard normal (stdlib: the Blender add-on's Python has no scipy)
_UNIFORM_LO, _UNIFORM_HI = _NORMAL.cdf(-TRUNCATION), _NORMAL.cdf(TRUNCATION)  # the truncation in u
#: the actuation noise stream: a sub-env's move at a step draws from (episode seed, NOISE_STREAM, step)
NOISE_STREAM = 0x6E6F6973


class NoiseConfigError(BioVLNError):
    """An unknown preset or noise option."""


@dataclass(frozen=True)
class TruncatedGaussian:
    """Independent components, each N(mean, variance) truncated to mean +- 3 sigma."""

    mean: tuple[float, ...]
    variance: tuple[float, ...]

    def sample(self, rng: np.random.Generator, n: int) -> np.ndarray:
        """(n, k) samples by inverse CDF (one uniform per value, so the stream is easy to replay)."""
        u = rng.uniform(_UNIFORM_LO, _UNIFORM_HI, (n, len(self.mean)))
        return np.array([self.values(row) for row in u.tolist()]).reshape(n, len(self.mean))

    def values(self, u: list[float]) -> list[float]:
        """The values of one sample from its uniforms ``u`` (one per component, in the truncated range):
        ``mean + sqrt(variance) * inv_cdf(u)``."""
        return [m + math.sqrt(v) * _NORMAL.inv_cdf(x) for m, v, x in zip(self.mean, self.variance, u)]


@dataclass(frozen=True)
class MotionNoise:
    """Errors of one kind of move: position (along, across) in metres, heading in radians."""

    position: TruncatedGaussian
    heading: TruncatedGaussian


#: LoCoBot, proportional controller: a forward move and a turn.
LOCOBOT_FORWARD = MotionNoise(
    TruncatedGaussian((0.017, 0.042), (0.007, 0.023)), TruncatedGaussian((0.031,), (0.026,))
)
LOCOBOT_TURN = MotionNoise(
    TruncatedGaussian((0.001, 0.005), (0.001, 0.004)), TruncatedGaussian((0.043,), (0.017,))
)


def actuation_uniforms(episode_seed: int, first_step: int, count: int) -> list[list[float]]:
    """The three uniforms (in the truncated range; position's two, then heading's) of each move at steps
    ``first_step`` to ``first_step + count - 1`` of an episode, from
    ``default_rng([episode_seed, NOISE_STREAM, step])``: stateless, so a replay from any saved state draws
    the same noise."""
    seeds = ([episode_seed, NOISE_STREAM, step] for step in range(first_step, first_step + count))
    return [np.random.default_rng(s).uniform(_UNIFORM_LO, _UNIFORM_HI, 3).tolist() for s in seeds]


def actuation_errors(
    u: list[float], forward: float, turn: float, multiplier: float
) -> tuple[float, float, float]:
    """(along, across, heading) errors of one commanded move (``forward`` m, ``turn`` rad) of one robot,
    from its three uniforms ``u`` (:func:`actuation_uniforms`)."""
    model = LOCOBOT_FORWARD if forward > 0 else LOCOBOT_TURN
    along, across = (x * multiplier for x in model.position.values(u[:2]))
    heading = model.heading.values(u[2:])[0] * multiplier
    return (along if forward >= 0 else -along), across, (heading if turn >= 0 else -heading)


@dataclass(frozen=True)
class NoiseConfig:
    """What is noisy. ``actuation``: multiplier of the LoCoBot errors (0: exact motion); ``rgb``: Gaussian
    RGB noise sigma on the [0, 1] intensity scale; ``depth``: structured-light depth noise; ``gps_compass``:
    the GPS, compass and PointGoal-with-GPS+compass sensors and the base odometry in ``obs["agent"]``
    (without them the goal comes once, as ``pointgoal`` in the start frame); ``sliding``: a move blocked by
    an obstacle slides along it (else the robot stays where it was, as Habitat's ``allow_sliding=False``)."""

    actuation: float = 0.0
    rgb: float = 0.0
    depth: bool = False
    gps_compass: bool = True
    sliding: bool = True

    @property
    def name(self) -> str:
        """The preset this is, or ``custom``."""
        return next((k for k, v in PRESETS.items() if v == self), "custom")


PRESETS: dict[str, NoiseConfig] = {
    "ideal": NoiseConfig(),
    "realistic": NoiseConfig(actuation=0.5, rgb=0.1, depth=True, gps_compass=False, sliding=False),
}


def resolve_noise(noise: str | dict[str, Any] | NoiseConfig | None) -> NoiseConfig:
    """A preset name, a dict (``preset`` plus field overrides) or a config; one-line errors otherwise."""
    if noise is None:
        return PRESETS["ideal"]
    if isinstance(noise, NoiseConfig):
        cfg, overrides = noise, {}
    elif isinstance(noise, str):
        cfg, overrides = _preset(noise), {}
    elif isinstance(noise, dict):
        overrides = dict(noise)
        cfg = _preset(str(overrides.pop("preset", "ideal")))
    else:
        raise NoiseConfigError(
            f"noise must be a preset name, a dict or a NoiseConfig, got {type(noise).__name__}",
            field="noise",
            fix=f"pass noise='realistic' or noise={{'preset': 'ideal', 'actuation': 0.5}}; presets: "
            f"{', '.join(PRESETS)}",
        )
    known = {f.name: f for f in fields(NoiseConfig)}
    for key, value in overrides.items():
        if key not in known:
            raise NoiseConfigError(
                f"unknown noise option '{key}'",
                field=f"noise.{key}",
                fix=f"use one of: preset, {', '.join(known)}",
            )
        kind = bool if known[key].type == "bool" else float
        if kind is bool and not isinstance(value, (bool, np.bool_)):
            raise NoiseConfigError(
                f"noise.{key} must be true or false, got {value!r}", field=f"noise.{key}", fix="pass a bool"
            )
        if kind is float and (
            isinstance(value, bool) or not isinstance(value, (int, float)) or not 0 <= value <= 10
        ):
            raise NoiseConfigError(
                f"noise.{key} must be a number in [0, 10], got {value!r}",
                field=f"noise.{key}",
                fix="pass e.g. 0.5 (0: no noise, 1: the published figures)",
            )
    return replace(cfg, **overrides)


def _preset(name: str) -> NoiseConfig:
    if name not in PRESETS:
        raise NoiseConfigError(
            f"unknown noise preset '{name}'", field="noise", fix=f"use one of: {', '.join(PRESETS)}"
        )
    return PRESETS[name]
