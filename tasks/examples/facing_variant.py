"""Example of a user task variant (the envs guide, "Adding a variant"): success also needs the robot to
face the instrument when it calls STOP. One measure plus a configuration; import this module, then
``gym.make("MyLab-OpFaceFacing-v0")``."""

from dataclasses import replace

from biovln_ms.metrics.measures import Measure, register_measure
from biovln_ms.registration import register_biovln_env
from biovln_ms.tasks.nav_env import BioVLNNavEnv
from biovln_ms.variants import BENCHMARK_ENV, VARIANTS


@register_measure
class FacingSuccess(Measure):
    """STOP within the success radius while the instrument is in view (a batched boolean per sub-env)."""

    uuid = "facing_success"
    dependencies = ("success", "facing_instrument")
    dtype = bool

    def compute(self, ctx, state, m, idx):
        return m["success"][idx] & m["facing_instrument"][idx]


@register_measure
class FacingFail(Measure):
    """STOP that is not a facing success ends the episode as a failure."""

    uuid = "facing_fail"
    dependencies = ("stopped", "facing_success")
    dtype = bool

    def compute(self, ctx, state, m, idx):
        return m["stopped"][idx] & ~m["facing_success"][idx]


BASE = VARIANTS[BENCHMARK_ENV]


@register_biovln_env("MyLab-OpFaceFacing-v0", max_episode_steps=BASE.max_episode_steps)
class FacingOpFaceEnv(BioVLNNavEnv):
    config = replace(
        BASE,
        measures=BASE.measures + ("facing_success",),
        success_measure="facing_success",
        fail_measure="facing_fail",
    )
