"""The user-facing episode arguments of the navigation envs, resolved to the episode source an env is handed.

``gym.make(env_id, split=..., dataset=..., template=..., scene_seed=...)`` reaches
:meth:`NavEnvSpec.make` (``biovln_ms.registration.register_biovln_env`` registers every navigation env with
it), which turns those arguments into an :class:`~biovln_ms.episodes.source.EpisodeSource` (a dataset split,
the default dataset built on first use, or episodes sampled in a generated scene) and makes the env with
``episodes=``. The env itself never builds a dataset.
"""

from __future__ import annotations

from mani_skill.utils.registration import EnvSpec

from biovln_ms.splits import dataset_root
from biovln_ms.episodes.source import DatasetEpisodes
from biovln_ms.robot_specs import DEFAULT_ROBOT, robot_spec
from biovln_ms.tasks.config_checks import EnvConfigError, check_source_arguments, task_config
from biovln_ms.tasks.nav_env import BioVLNNavEnv

#: the arguments an episode source is resolved from
SOURCE_ARGUMENTS = ("split", "dataset", "template", "scene_seed")


def resolve_episodes(env_cls: type[BioVLNNavEnv], kwargs: dict) -> dict:
    """``kwargs`` for ``env_cls`` with ``episodes=`` in place of ``split`` (of ``dataset``, or the robot's
    default dataset; the config's ``default_split`` when none), or without a split the episodes sampled in
    the scene generated from ``template`` / ``scene_seed``. A split whose episodes bring their own crowds
    (the busy splits) sets ``people`` to its largest crowd when not given. The env's own argument checks run
    first, so an invalid argument is reported before any dataset is read or built."""
    kwargs = dict(kwargs)
    given = {k: kwargs.pop(k) for k in SOURCE_ARGUMENTS if k in kwargs}
    check_source_arguments(given)
    if "episodes" in kwargs:
        if given:
            name = next(iter(given))
            raise EnvConfigError(
                f"episodes= was given with {name}=",
                field=name,
                fix="pass the episode source or its arguments",
            )
        return kwargs
    cfg = task_config(env_cls.config, kwargs.get("control_mode", "discrete"), dict(kwargs))
    robot = robot_spec(kwargs.get("robot_uids", DEFAULT_ROBOT)).uid
    split, dataset = given.get("split") or cfg.default_split, given.get("dataset")
    if split:
        kwargs["episodes"] = DatasetEpisodes.shared(split, dataset_root(dataset, robot), robot)
        crowd = max((e["people"]["count"] for e in kwargs["episodes"].episodes if "people" in e), default=0)
        if crowd and "people" not in kwargs:  # a busy split: figures for its largest crowd
            kwargs["people"] = max(crowd, cfg.people)
    elif dataset:
        raise EnvConfigError(
            f"a dataset ({dataset}) was given without a split",
            field="split",
            fix="pass split=, e.g. split='ms_val'",
        )
    else:
        template = given.get("template", env_cls.default_template)
        kwargs["episodes"] = env_cls.generated_episodes(template, given.get("scene_seed", 0), robot=robot)
    return kwargs


class NavEnvSpec(EnvSpec):
    """ManiSkill's env spec of a navigation env: its episode arguments are resolved before the env is made."""

    @classmethod
    def of(cls, spec: EnvSpec) -> NavEnvSpec:
        return cls(spec.uid, spec.cls, spec.max_episode_steps, spec.asset_download_ids, spec.default_kwargs)

    def make(self, **kwargs):
        return super().make(**resolve_episodes(self.cls, {**self.default_kwargs, **kwargs}))
