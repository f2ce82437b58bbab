"""Example of a user task variant (README, "Adding a task variant"): success also needs the robot to
face the instrument when it calls STOP. Import this module, then ``gym.make("MyLab-OpFaceFacing-v0")``."""

from biovln_ms.metrics.measures import Measure, MeasureSet, register_measure
from biovln_ms.metrics.measures import END_INFO, STEP_INFO
from biovln_ms.registration import register_biovln_env
from biovln_ms.tasks.nav_env import BioVLNNavEnv


@register_measure
class FacingSuccess(Measure):
    """STOP within the success radius while the instrument is in view."""

    uuid = "facing_success"
    dependencies = ("success", "facing_instrument")

    def update(self, ctx, state, m):
        self.value = bool(m["success"] and m["facing_instrument"])


@register_biovln_env("MyLab-OpFaceFacing-v0", max_episode_steps=500)
class FacingOpFaceEnv(BioVLNNavEnv):
    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self._measures = MeasureSet(names=STEP_INFO + END_INFO + ("facing_success",))

    def evaluate(self):
        info = super().evaluate()
        if "facing_success" in info:
            info["success"] = info["facing_success"]  # the stricter rule decides success
            info["fail"] = info["stopped"] & ~info["success"]
        return info
