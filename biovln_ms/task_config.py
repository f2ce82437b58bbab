"""The navigation task's configuration (paper §3.2, Eq. 5, appendix "Gym Environment for RL Training").

Pure data: the env (:mod:`biovln_ms.tasks.nav_env`), its measures and sensors read it; a variant is
one :class:`NavTaskConfig` (a :class:`ProtocolTaskConfig` for lab protocols) in
:data:`biovln_ms.variants.VARIANTS`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Any

from biovln_ms.noise import NoiseConfig

#: The action codes of the paper's action space (the env's ``Discrete(4)``), shared by the env, the
#: policies and the learning code.
STOP, FORWARD, TURN_LEFT, TURN_RIGHT = 0, 1, 2, 3

#: Per-step info of every variant (paper §4.2) and the episode-end metrics.
STEP_MEASURES = (
    "success",
    "distance_to_goal",
    "geodesic_distance_to_goal",
    "clearance",
    "zone2_violation",
    "in_zone3",
    "facing_instrument",
    "collisions",
    "strict_success",
    "stopped",
)
END_MEASURES = ("spl", "soft_spl", "mcr", "vrt", "steps", "path_length")
#: The sensors of the benchmark env (Habitat's PointNav/ObjectNav sensors; see ``baselines.policy``).
NAV_SENSORS = ("gps", "compass", "pointgoal_with_gps_compass", "objectgoal")
#: What GPS+compass gives, and what replaces each without it (None: nothing). The paper's RL state vector is
#: the robot's pose too: without it the goal comes once, as for the others; a policy keeps its own estimate
GPS_COMPASS_SENSORS = {
    "gps": None,
    "compass": None,
    "pointgoal_with_gps_compass": "pointgoal",
    "rl_state": "pointgoal",
}
#: Info of the protocol (multi-goal) variants: the current goal and per-goal state, every step
#: (``biovln_ms.metrics.protocol_measures``, docs/guides/protocols.md) ...
PROTOCOL_STEP_MEASURES = (
    "subgoal_index",
    "num_goals",
    "subgoal_status",
    "subgoal_found",
    "wrong_stop",
    "subgoal_position",
    "distance_to_subgoal",
    "geodesic_distance_to_subgoal",
    "clearance",
    "zone2_violation",
    "collisions",
    "step_budget",
    "out_of_budget",
)
#: ... and the episode metrics
PROTOCOL_END_MEASURES = (
    "protocol_success",
    "progress",
    "ppl",
    "stage_success",
    "mcr",
    "vrt",
    "zone2_steps",
    "steps",
    "path_length",
)
#: What the protocol variants' observation adds: the instruction as token ids and as UTF-8 text
INSTRUCTION_SENSORS = ("instruction", "instruction_text")


@dataclass(frozen=True)
class NavTaskConfig:
    """Task parameters. ``measures`` are reported in ``info``; reward, success and fail are measures too."""

    forward_step: float = 0.25
    turn_deg: float = 30.0
    goal_mode: str = "opface"  # "opface" (Eq. 1) or "centroid" (Table 9 ablation)
    max_episode_steps: int = 500  # the paper's step limit (§4.2)
    camera_width: int = 640
    camera_height: int = 480
    camera_hfov_deg: float = 79.0  # Habitat's horizontal FOV; SAPIEN takes the vertical one
    strict_facing_deg: float = 30.0  # facing_face / strict success: the heading within this of the face's -f
    camera_far: float = 20.0
    success_bonus: float = 10.0
    step_penalty: float = 0.01
    safety_penalty: float = 0.05
    proportional_safety: bool = False  # RL variant: penalty * (1 - clearance / 0.5)
    shuffle_episodes: bool = (
        False  # RL variant: shuffle once (scene order, and episodes within a scene), then cycle
    )
    #: with shuffle_episodes: this many of each scene's episodes per pass over the scenes, so training meets
    #: more scenes per step (ManiSkill's reconfiguration_freq in spirit); 0: all of a scene's at once
    scene_visit_episodes: int = 0
    position_scale: float = 4.0  # RL variant observation normalisation (m)
    measures: tuple[str, ...] = STEP_MEASURES + END_MEASURES
    reward_measure: str = "nav_reward"
    success_measure: str = "success"
    fail_measure: str = "failed_stop"
    sensors: tuple[str, ...] = NAV_SENSORS
    agent_obs: bool = True  # ManiSkill's proprioception (base joint qpos/qvel) in state observations
    default_split: str | None = None  # the split used when none is given (None: a generated scene)
    default_obs_mode: str = "state"
    lighting: str = "fast"  # a preset of biovln_ms.render.lighting.LIGHTING: "fast" or "quality" (shadows)
    noise: NoiseConfig = field(default_factory=NoiseConfig)  # biovln_ms.noise: the paper's is ideal
    people: int = 0  # technicians walking the lab (biovln_ms.people, docs/guides/people.md); 0: none
    person_collision_ends: bool = True  # with people: a collision with a person ends the episode, failed

    @property
    def protocol(self) -> bool:
        """Whether episodes are lab protocols (K ordered goals): :class:`ProtocolTaskConfig`'s are."""
        return False

    def with_noise(self, noise: NoiseConfig) -> "NavTaskConfig":
        """This config under ``noise``: without GPS+compass, its sensors lose them (the goal comes once, as
        ``pointgoal`` in the start frame) and the observation loses the base odometry."""
        if noise.gps_compass:
            return replace(self, noise=noise)
        sensors = tuple(
            dict.fromkeys(
                GPS_COMPASS_SENSORS.get(s, s) for s in self.sensors if GPS_COMPASS_SENSORS.get(s, s)
            )
        )
        return replace(self, noise=noise, sensors=sensors, agent_obs=False)

    def step_budget(self, k: int) -> int:
        """The step budget of an episode with ``k`` goals: ``max_episode_steps`` for single-goal episodes."""
        return self.max_episode_steps

    def task_spec(
        self, goal_categories: tuple[str, ...], control_mode: str, robot_radius: float
    ) -> "TaskSpec":
        """What a policy is told of this task, for a control mode and a robot."""
        return TaskSpec(
            self.forward_step,
            self.turn_deg,
            self.camera_hfov_deg,
            self.max_episode_steps,
            goal_categories,
            control_mode,
            robot_radius,
            self.noise,
            self.position_scale,
            self.people,
        )

    @property
    def camera_vfov(self) -> float:
        """Vertical FOV (radians) for SAPIEN from the horizontal one: 2 atan(tan(h/2) H/W)."""
        return 2 * math.atan(
            math.tan(math.radians(self.camera_hfov_deg) / 2) * self.camera_height / self.camera_width
        )

    @property
    def hfov(self) -> float:
        return math.radians(self.camera_hfov_deg)


@dataclass(frozen=True)
class ProtocolTaskConfig(NavTaskConfig):
    """A lab protocol task (``BioVLN-Protocol-v0``, docs/guides/protocols.md): an episode is K = 2-5 ordered
    goals, a STOP at each (MultiON's FOUND). The options below are this task's only."""

    steps_per_goal: int = 500  # an episode's step budget is steps_per_goal x K
    wrong_stop: str = "end"  # a STOP away from the current goal "end"s the episode, or is a "miss"
    subgoal_rule: str = "radius"  # a correct STOP is within r; "strict": in Zone 3, facing the face

    @property
    def protocol(self) -> bool:
        return True

    def step_budget(self, k: int) -> int:
        """``steps_per_goal`` x ``k`` for an episode of ``k`` goals."""
        return self.steps_per_goal * k


@dataclass(frozen=True)
class TaskSpec:
    """What the action space means and what the task asks (public, as a robot's configuration)."""

    forward_step: float  # m per FORWARD
    turn_deg: float  # degrees per TURN_LEFT / TURN_RIGHT
    hfov_deg: float  # head camera's horizontal field of view
    max_episode_steps: int
    goal_categories: tuple[str, ...]  # the order of the ``objectgoal`` one-hot
    control_mode: str  # "discrete" or "continuous"
    robot_radius: float  # m, the robot's body
    noise: NoiseConfig = field(default_factory=NoiseConfig)  # what is noisy and what the robot senses
    position_scale: float = NavTaskConfig.position_scale  # m: the RL state vector's positions are over this
    people: int = 0  # technicians may walk the lab (NavTaskConfig.people): a policy's map must forget them


@dataclass(frozen=True)
class EpisodeInfo:
    """The episode as a policy may know it: ids, the target category, the task, and for oracles only
    the privileged view."""

    scene_id: str
    episode_id: Any
    object_category: str
    task: TaskSpec
    privileged: Any = None
    instruction: str | None = None  # a protocol episode's English instruction (None: single-goal episodes)
