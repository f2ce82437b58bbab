"""A plugin module, as a user writes one (the extending guide): a success rule, a variant that uses it, a
sensor, a method and a scene template, registered from outside the package. Load it with
``biovln-ms --plugin path/to/lab_plugin.py ...`` or ``biovln_ms.load_plugins(["path/to/lab_plugin.py"])``."""

from dataclasses import replace

import numpy as np

from biovln_ms import register_variant
from biovln_ms.eval.methods import MethodSpec, register_method
from biovln_ms.metrics.measures import Measure, Metric, rate, register_measure
from biovln_ms.scene.templates import get_template, register_template
from biovln_ms.tasks.sensors import register_sensor
from biovln_ms.variants import BENCHMARK_ENV, VARIANTS


@register_measure
class Zone3FacingSuccess(Measure):
    """STOP inside a goal's Zone 3, facing its operational face within the variant's strict_facing_deg."""

    uuid = "zone3_facing_success"
    metric = Metric("zone3_facing_success", aggregates=(rate("zone3_facing_sr", "Zone-3 facing SR"),))
    dtype = bool
    dependencies = ("stopped", "in_zone3", "facing_face")

    def compute(self, ctx, s, m, idx):
        return m["stopped"][idx] & m["in_zone3"][idx] & m["facing_face"][idx]


@register_measure
class Zone3FacingFail(Measure):
    """A STOP that is not a Zone-3 facing success ends the episode as a failure."""

    uuid = "zone3_facing_fail"
    dtype = bool
    dependencies = ("stopped", "zone3_facing_success")

    def compute(self, ctx, s, m, idx):
        return m["stopped"][idx] & ~m["zone3_facing_success"][idx]


BASE = VARIANTS[BENCHMARK_ENV]
register_variant(
    "MyLab-Zone3Facing-v0",
    replace(
        BASE,
        measures=BASE.measures + ("zone3_facing_success",),
        success_measure="zone3_facing_success",
        fail_measure="zone3_facing_fail",
        strict_facing_deg=15.0,
        sensors=BASE.sensors + ("heading_vector",),
    ),
)


@register_sensor("heading_vector")
def heading_vector(x):
    """The robot's heading as a unit vector (cos, sin) in the world frame."""
    yaw = x.pose[:, 2]
    return np.stack([np.cos(yaw), np.sin(yaw)], axis=1).astype(np.float32)


class StopAtOnce:
    """A policy: STOP at the first step (a floor for any method's success rate)."""

    def reset(self, episode_info) -> None:
        pass

    def act(self, obs, info) -> int:
        return 0


register_method(
    "stop_at_once",
    MethodSpec(
        StopAtOnce,
        "state",
        "STOP at the first step",
        label="Stop at once",
        report_order=1000,
        env_id="MyLab-Zone3Facing-v0",
    ),
)

# a template: the shipped single room under another name (or a JSON file of the scenes guide's format)
register_template(get_template("single_room").model_copy(update={"name": "my_single_room"}))
