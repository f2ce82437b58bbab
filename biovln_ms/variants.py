"""Every navigation env this package registers, declared once: id -> task configuration.

``biovln_ms.registration`` registers them lazily with gymnasium and ``biovln_ms.tasks.variant_envs`` with
ManiSkill, both from this table. A new variant is one entry (or a new measure, see the envs guide).
"""

from __future__ import annotations

from dataclasses import replace

from biovln_ms.constants import MAX_VISITS
from biovln_ms.task_config import (
    INSTRUCTION_SENSORS,
    NAV_SENSORS,
    PROTOCOL_END_MEASURES,
    PROTOCOL_STEP_MEASURES,
    NavTaskConfig,
    ProtocolTaskConfig,
)

#: the busy variants' figures: the busy splits' largest crowd (biovln_ms.splits.BUSY_MAX_PEOPLE)
BUSY_PEOPLE = 4
#: the busy protocol variant's people: every protocol split's scene has faces for them apart from the start
PROTOCOL_PEOPLE = 2

# lab protocols: K = 2-5 ordered goals, a STOP at each; the step budget is steps_per_goal x K,
# and the registered step limit (gymnasium's truncation) the largest budget, steps_per_goal x MAX_VISITS
_PROTOCOL = ProtocolTaskConfig(
    measures=PROTOCOL_STEP_MEASURES + PROTOCOL_END_MEASURES,
    reward_measure="protocol_reward",
    success_measure="protocol_success",
    fail_measure="protocol_fail",
    sensors=NAV_SENSORS + INSTRUCTION_SENSORS,
)
_PROTOCOL = replace(_PROTOCOL, max_episode_steps=_PROTOCOL.step_budget(MAX_VISITS))

# the paper's Gym variant for RL: 10 deg turns, positions / 4.0 m, heading as a unit vector,
# Eq. 5 with the proportional safety penalty, episodes shuffled once and cycled
_RL = NavTaskConfig(
    turn_deg=10.0,
    proportional_safety=True,
    safety_penalty=1.0,
    shuffle_episodes=True,
    sensors=("rl_state", "objectgoal"),
    agent_obs=False,
    default_split="train",
)

_STRICT = NavTaskConfig(success_measure="strict_success", fail_measure="strict_failed_stop")


def _busy(cfg: NavTaskConfig) -> NavTaskConfig:
    """``cfg`` with people in the lab: BUSY_PEOPLE figures, the busy_val split by default."""
    return replace(cfg, people=BUSY_PEOPLE, default_split="busy_val")


#: the env ids, each defined here once
BENCHMARK_ENV = "BioVLN-OpFace-v0"
CENTROID_ENV = "BioVLN-Centroid-v0"
STRICT_ENV = "BioVLN-OpFace-Strict-v0"
RL_ENV = "BioVLN-OpFace-RL-v0"
BUSY_ENV = "BioVLN-OpFace-Busy-v0"
BUSY_STRICT_ENV = "BioVLN-OpFace-Busy-Strict-v0"
RL_BUSY_ENV = "BioVLN-OpFace-RL-Busy-v0"
PROTOCOL_ENV = "BioVLN-Protocol-v0"
PROTOCOL_STRICT_ENV = "BioVLN-Protocol-Strict-v0"
PROTOCOL_BUSY_ENV = "BioVLN-Protocol-Busy-v0"
LAB_SCENE_ENV = "BioVLN-LabScene-v0"  # the scene viewer (no task; not a variant)

VARIANTS: dict[str, NavTaskConfig] = {
    # the benchmark (paper §3.2): Eq. 1 goals, 0.25 m / 30 deg actions, 500 steps
    BENCHMARK_ENV: NavTaskConfig(),
    # the paper's ablation (Table 9): the goal is the floor projection of the bounding-box centre
    CENTROID_ENV: NavTaskConfig(goal_mode="centroid"),
    # operational success: STOP within r in Zone 3, facing the face within 30 deg (strict_success)
    STRICT_ENV: _STRICT,
    # the paper's Gym variant for RL (above)
    RL_ENV: _RL,
    # people in the lab (docs/guides/people.md): the busy splits, each episode with its own crowd of 1-4
    # technicians (up to 4 figures; a split or scene without crowds gets 4 people)
    BUSY_ENV: _busy(NavTaskConfig()),
    # ... and operational success, which with people also needs the goal's Zone 3 free of them
    BUSY_STRICT_ENV: _busy(_STRICT),
    # ... and the RL variant with them (its state vector has no people: a policy trained on RL-v0 runs blind)
    RL_BUSY_ENV: _busy(_RL),
    # lab protocols: a correct STOP is within the current goal's success radius r
    PROTOCOL_ENV: _PROTOCOL,
    # ... and also in its Zone 3, facing its operational face within 30 deg (strict_success's rule)
    PROTOCOL_STRICT_ENV: replace(_PROTOCOL, subgoal_rule="strict"),
    # ... with people: PROTOCOL_PEOPLE technicians drawn from each episode's seed (the protocol splits carry
    # no crowds); a person collision ends the episode, failed
    PROTOCOL_BUSY_ENV: replace(_PROTOCOL, people=PROTOCOL_PEOPLE),
}

#: each variant's counterpart with people in the lab (the benchmark suite and the report pair them)
WITH_PEOPLE = {
    BENCHMARK_ENV: BUSY_ENV,
    STRICT_ENV: BUSY_STRICT_ENV,
    RL_ENV: RL_BUSY_ENV,
    PROTOCOL_ENV: PROTOCOL_BUSY_ENV,
}
