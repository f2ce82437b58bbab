"""ManiSkill tasks of BioVLN-MS (installed as ``biovln_ms.tasks``). Importing this registers them."""

from biovln_ms.tasks import lab_scene_env, nav_env, variant_envs  # noqa: F401


def make_lazy(env_id: str, **kwargs):
    """Entry point of the lazy gymnasium specs (:mod:`biovln_ms.registration`): gymnasium imports this
    package to resolve it, which has registered the tasks with ManiSkill; then ManiSkill builds the env."""
    from mani_skill.utils.registration import make

    return make(env_id, **kwargs)


def make_sub_env(env_id: str, **kwargs):
    """Entry point of ``gym.make_vec``'s sub-envs (:class:`biovln_ms.registration.VectorisableSpec`): the
    NumPy env of :func:`biovln_ms.wrappers.make_gym_env`, with one torch thread in a worker process.

    The first sub-env of a process whose program chose no start method sets ``forkserver`` (Python 3.14's
    default on Linux): ``AsyncVectorEnv`` builds a sub-env in this process before it starts its workers,
    and a worker forked from a process that has started SAPIEN deadlocks."""
    import multiprocessing as mp

    from biovln_ms.wrappers import make_gym_env

    if mp.get_start_method(allow_none=True) is None:
        mp.set_start_method("forkserver")
    return make_gym_env(env_id, single_thread=mp.parent_process() is not None, **kwargs)
