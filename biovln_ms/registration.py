"""Registering BioVLN envs with ManiSkill and gymnasium.

``import biovln_ms`` registers every id with gymnasium lazily (ManiSkill, torch and SAPIEN take ~3 s to
import, which CLI commands that never simulate should not pay). The first ``gym.make`` of an id
imports :mod:`biovln_ms.tasks`, whose classes register with ManiSkill through
:func:`register_biovln_env`; that replaces the lazy gymnasium spec with ManiSkill's own.
"""

from __future__ import annotations

from biovln_ms.variants import VARIANTS

#: uid -> max_episode_steps of every env this package provides (the variants' own, and the scene viewer).
ENV_IDS: dict[str, int] = {
    **{uid: cfg.max_episode_steps for uid, cfg in VARIANTS.items()},
    "BioVLN-LabScene-v0": 1,
}


def register_lazily() -> None:
    import gymnasium as gym
    from gymnasium.envs.registration import WrapperSpec

    for uid, steps in ENV_IDS.items():
        if uid in gym.registry:
            continue
        gym.register(
            uid,
            entry_point="biovln_ms.registration:make_lazy",
            kwargs={"env_id": uid},
            max_episode_steps=steps,
            disable_env_checker=True,
            additional_wrappers=(
                WrapperSpec(
                    "MSTimeLimit",
                    "mani_skill.utils.registration:TimeLimitWrapper",
                    {"max_episode_steps": steps},
                ),
            ),
        )


def make_lazy(env_id: str, **kwargs):
    """Entry point of the lazy specs: import the tasks (real registration), then build the env."""
    import biovln_ms.tasks  # noqa: F401
    from mani_skill.utils.registration import make

    return make(env_id, **kwargs)


def register_biovln_env(uid: str, max_episode_steps: int, **kwargs):
    """ManiSkill's ``register_env``, after dropping this package's lazy gymnasium spec of ``uid``."""
    import gymnasium as gym
    from mani_skill.utils.registration import register_env

    spec = gym.registry.get(uid)
    if spec is not None and spec.entry_point == "biovln_ms.registration:make_lazy":
        del gym.registry[uid]
    return register_env(uid, max_episode_steps=max_episode_steps, **kwargs)
