"""ManiSkill tasks of BioVLN-MS (installed as ``biovln_ms.tasks``). Importing this registers them."""

from biovln_ms.tasks import lab_scene_env, nav_env, variant_envs  # noqa: F401


def make_lazy(env_id: str, **kwargs):
    """Entry point of the lazy gymnasium specs (:mod:`biovln_ms.registration`): gymnasium imports this
    package to resolve it, which has registered the tasks with ManiSkill; then ManiSkill builds the env."""
    from mani_skill.utils.registration import make

    return make(env_id, **kwargs)
