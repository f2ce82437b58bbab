"""Registering BioVLN envs with ManiSkill and gymnasium.

``import biovln_ms`` registers every id with gymnasium lazily (ManiSkill, torch and SAPIEN take seconds to
import, which CLI commands that never simulate should not pay). The first ``gym.make`` of an id
imports :mod:`biovln_ms.tasks` (the specs' entry point is ``biovln_ms.tasks.make_lazy``), whose classes
register with ManiSkill through :func:`register_biovln_env`. The gymnasium spec stays this module's
(:class:`VectorisableSpec`, not ManiSkill's), so ``gym.make`` and ``gym.make_vec`` behave the same before
and after that import.
"""

from __future__ import annotations

import copy
from collections.abc import Callable

from gymnasium.envs.registration import EnvSpec, WrapperSpec

from biovln_ms.errors import BioVLNError
from biovln_ms.task_config import NavTaskConfig
from biovln_ms.variants import LAB_SCENE_ENV, VARIANTS

#: uid -> max_episode_steps of every env this package provides (the variants' own, and the scene viewer).
ENV_IDS: dict[str, int] = {
    **{uid: cfg.max_episode_steps for uid, cfg in VARIANTS.items()},
    LAB_SCENE_ENV: 1,
}
#: The ids this package ships, with their configurations (None: not a navigation variant). Their gymnasium
#: specs' ids are ``biovln_ms:<id>`` (:func:`spec_id`).
SHIPPED: dict[str, NavTaskConfig | None] = {**VARIANTS, LAB_SCENE_ENV: None}
#: The lazy specs' entry point. Gymnasium resolves it by name on the first ``gym.make``, and resolving it
#: imports :mod:`biovln_ms.tasks`, which registers every env; it lives there so that this module, which the
#: tasks import, never imports them back.
LAZY_ENTRY_POINT = "biovln_ms.tasks:make_lazy"
#: the entry point of ``gym.make_vec``'s sub-envs (:class:`VectorisableSpec`)
SUB_ENV_ENTRY_POINT = "biovln_ms.tasks:make_sub_env"


class VectorisableSpec(EnvSpec):
    """The gymnasium spec of a BioVLN env. ``gym.make`` builds the ManiSkill env, whose observations are
    batched torch tensors as every ManiSkill env's. ``gym.make_vec`` (``sync`` or ``async``) builds its
    sub-envs from a deep copy of the registered spec; that copy's entry point makes each sub-env the
    NumPy env gymnasium's vector envs stack (``biovln_ms.tasks.make_sub_env``), so N sub-envs give
    ``(N, obs_dim)`` where ManiSkill's envs would give ``(N, 1, obs_dim)``."""

    def __deepcopy__(self, memo) -> EnvSpec:
        return EnvSpec(
            id=self.id,
            entry_point=SUB_ENV_ENTRY_POINT,
            kwargs=copy.deepcopy(self.kwargs, memo),
            max_episode_steps=self.max_episode_steps,
            disable_env_checker=True,
        )


def spec_id(uid: str) -> str:
    """The id an env's ``spec.id`` gives, which ManiSkill's ``RecordEpisode`` writes into a recording's
    JSON: ``biovln_ms:<uid>`` for an id this package ships with its shipped configuration, gymnasium's
    "module:id" form, so that ``gym.make`` of it in a process that never imported this package (ManiSkill's
    ``replay_trajectory``) imports it first. An id registered from your code stays ``uid``: importing this
    package does not register it."""
    if uid in SHIPPED and VARIANTS.get(uid) == SHIPPED[uid]:
        return f"biovln_ms:{uid}"
    return uid


def gym_spec(uid: str, max_episode_steps: int) -> VectorisableSpec:
    """The gymnasium spec of env ``uid`` (registered under ``uid``, its id :func:`spec_id`'s): built by
    ``biovln_ms.tasks.make_lazy`` and limited to ``max_episode_steps`` by ManiSkill's ``TimeLimitWrapper``
    (batched truncation), as ManiSkill's own registration does."""
    return VectorisableSpec(
        id=spec_id(uid),
        entry_point=LAZY_ENTRY_POINT,
        kwargs={"env_id": uid},
        max_episode_steps=max_episode_steps,
        disable_env_checker=True,
        additional_wrappers=(
            WrapperSpec(
                "MSTimeLimit",
                "mani_skill.utils.registration:TimeLimitWrapper",
                {"max_episode_steps": max_episode_steps},
            ),
        ),
    )


#: called with (uid, config) for a variant registered after the tasks were imported (set by the tasks)
VARIANT_HOOKS: list[Callable[[str, NavTaskConfig], None]] = []


def register_variant(uid: str, cfg: NavTaskConfig, override: bool = False) -> None:
    """A new env id from your code, e.g. ``register_variant("MyLab-Zone3-v0", replace(VARIANTS[...], ...))``:
    ``gym.make(uid)`` then builds it as a shipped variant, and evaluation and the CLI's lists know it. A
    taken id with another configuration is refused unless ``override``."""
    if not isinstance(uid, str) or not uid.rsplit("-v", 1)[-1].isdigit():
        raise BioVLNError(
            f"env id {uid!r} has no version suffix", field="uid", fix="name it like 'MyLab-Zone3-v0'"
        )
    if not isinstance(cfg, NavTaskConfig):
        raise BioVLNError(
            f"the configuration of {uid} is a {type(cfg).__name__}",
            field="cfg",
            fix="pass a NavTaskConfig (dataclasses.replace of a shipped variant's)",
        )
    if VARIANTS.get(uid, cfg) != cfg and not override:
        raise BioVLNError(f"env id {uid} is already registered", field="uid", fix="choose another id")
    VARIANTS[uid] = cfg
    ENV_IDS[uid] = cfg.max_episode_steps
    for hook in VARIANT_HOOKS:
        hook(uid, cfg)
    register_lazily()


def register_lazily() -> None:
    import gymnasium as gym

    for uid, steps in ENV_IDS.items():
        if uid not in gym.registry:
            gym.registry[uid] = gym_spec(uid, steps)


def register_biovln_env(uid: str, max_episode_steps: int, **kwargs):
    """ManiSkill's ``register_env``, with this package's gymnasium spec of ``uid`` (:func:`gym_spec`) in
    place of ManiSkill's (its lazy one is dropped first: ManiSkill warns on a taken id). A
    navigation env's ManiSkill spec resolves ``split=`` / ``dataset=`` / ``template=`` / ``scene_seed=`` to
    the episode source the env is handed (:mod:`biovln_ms.tasks.episode_sources`)."""
    import gymnasium as gym
    from mani_skill.utils.registration import REGISTERED_ENVS, register_env

    spec = gym.registry.get(uid)
    if spec is not None and spec.entry_point == LAZY_ENTRY_POINT:
        del gym.registry[uid]
    register = register_env(uid, max_episode_steps=max_episode_steps, **kwargs)

    def wrap(cls):
        register(cls)
        from biovln_ms.tasks.episode_sources import NavEnvSpec
        from biovln_ms.tasks.nav_env import BioVLNNavEnv

        ms_spec = REGISTERED_ENVS.get(uid)
        if issubclass(cls, BioVLNNavEnv) and ms_spec is not None and not isinstance(ms_spec, NavEnvSpec):
            REGISTERED_ENVS[uid] = NavEnvSpec.of(ms_spec)
        gym.registry[uid] = gym_spec(uid, max_episode_steps)  # in place of ManiSkill's
        return cls

    return wrap
