"""What differs between the ManiSkill builds the package runs on, in one place: mani-skill 3.0.1 (the pin),
ManiSkill's nightly (``mani-skill-nightly``, the same import name ``mani_skill``) and what ManiSkill 4
announces. Each difference is found by looking for the feature, not by comparing version strings (the
nightly's ``mani_skill.__version__`` still reads 3.0.1). The table of differences, with what the package
does about each, is in docs/guides/envs-and-variants/maniskill.md; scripts/check_maniskill_nightly.sh runs
the env's smoke tests against the nightly.

* :func:`maniskill_distribution`: which distribution installed ``mani_skill`` and its version.
* :func:`parse_sensor_configs`, :func:`update_sensor_configs_from_dict`: ManiSkill's sensor-config helpers,
  named ``parse_camera_configs`` / ``update_camera_configs_from_dict`` in 3.0.1.
* :data:`STEREO_DEPTH_CAMERA`: whether ``BaseEnv`` builds ``StereoDepthCamera`` sensors (the nightly
  refuses them); the task's ``sensor_configs`` never asks for one.
* :func:`maniskill_task_id`: the registered id of one of ManiSkill's own tasks (``PickCube`` ->
  ``PickCube-v1``; ManiSkill 4 announces ``-v4`` ids).
* :class:`FreezesLiveObjects`: ``BaseEnv._clear`` (every scene change) ends in a full ``gc.collect()``;
  the objects alive before an env is made are frozen (:func:`freeze_live_objects`), so it walks less.
* the physics rates are the task's own (``biovln_ms.tasks.config_checks.SIM_FREQUENCIES``), set by every
  env of the package, never ManiSkill's default (ManiSkill 4 announces 120 Hz physics).
"""

from __future__ import annotations

import functools
import gc
import importlib.util
import re
import weakref
from importlib import metadata
from pathlib import Path

import mani_skill.envs.sapien_env as _sapien_env
import mani_skill.sensors.camera as _camera

from biovln_ms.errors import BioVLNError
from biovln_ms.geometry.navigation import load_kernels

#: ManiSkill's sensor-config helpers: ``parse_sensor_configs`` (a config, list or dict of configs -> a dict
#: by uid) and ``update_sensor_configs_from_dict`` (configs updated in place from a ``sensor_configs``-style
#: dict); the nightly renamed 3.0.1's camera-named ones
parse_sensor_configs = getattr(_camera, "parse_sensor_configs", None) or _camera.parse_camera_configs
update_sensor_configs_from_dict = (
    getattr(_camera, "update_sensor_configs_from_dict", None) or _camera.update_camera_configs_from_dict
)
#: whether ``BaseEnv._setup_sensors`` builds a ``StereoDepthCameraConfig`` (3.0.1) or raises (the nightly,
#: which no longer imports the sensor class where sensors are built)
STEREO_DEPTH_CAMERA = hasattr(_sapien_env, "StereoDepthCamera")
#: the distributions that install the ``mani_skill`` package
DISTRIBUTIONS = ("mani-skill", "mani-skill-nightly")
_ID = re.compile(r"^(?P<name>.+)-v(?P<version>\d+)$")


@functools.cache
def maniskill_distribution() -> tuple[str, str]:
    """``(distribution, version)`` of the installed ``mani_skill``, e.g. ``("mani-skill", "3.0.1")`` or
    ``("mani-skill-nightly", "2026.8.2.400")``: the distribution whose files hold the ``mani_skill`` that
    imports (several may be installed side by side); ``("mani-skill", "NOT INSTALLED")`` when none does."""
    spec = importlib.util.find_spec("mani_skill")
    if spec is None or spec.origin is None:
        return DISTRIBUTIONS[0], "NOT INSTALLED"
    origin = Path(spec.origin).resolve()
    names = metadata.packages_distributions().get("mani_skill", [])
    found = []
    for name in dict.fromkeys([*names, *DISTRIBUTIONS]):
        try:
            dist = metadata.distribution(name)
        except metadata.PackageNotFoundError:
            continue
        found.append((re.sub(r"[-_.]+", "-", dist.metadata["Name"]).lower(), dist.version))
        if Path(dist.locate_file("mani_skill/__init__.py")).resolve() == origin:
            return found[-1]
    return found[0] if found else (DISTRIBUTIONS[0], "unknown (no distribution lists mani_skill)")


def maniskill_task_id(name: str) -> str:
    """The id under which the installed ManiSkill registers its own task ``name`` (``"PickCube"`` ->
    ``"PickCube-v1"``), the highest ``-vN`` where several are registered; a full id is checked as given.
    Imports ``mani_skill.envs`` (which registers ManiSkill's tasks)."""
    import mani_skill.envs  # noqa: F401  (registers ManiSkill's tasks)
    from mani_skill.utils.registration import REGISTERED_ENVS

    if name in REGISTERED_ENVS:
        return name
    versions = {
        int(m["version"]): uid for uid in REGISTERED_ENVS if (m := _ID.match(uid)) and m["name"] == name
    }
    if not versions:
        near = sorted(uid for uid in REGISTERED_ENVS if uid.lower().startswith(name.lower()[:4]))[:5]
        raise BioVLNError(
            f"ManiSkill {maniskill_distribution()[1]} registers no task {name!r}",
            field="name",
            fix=f"name one of its tasks without the -vN suffix (near: {', '.join(near) or 'none'})",
        )
    return versions[max(versions)]


#: an episode source of more episodes than this is frozen again at an env made with it
FREEZE_EPISODES = 10_000
_LIVE: weakref.WeakSet = weakref.WeakSet()  # the envs made through FreezesLiveObjects, while they live


def freeze_live_objects(episodes: int) -> None:
    """Collect, then freeze what is alive (``gc.freeze``): the imported libraries, Numba's typing
    registries (built first, :func:`~biovln_ms.geometry.navigation.load_kernels`: the env's geometry would
    build them after the freeze) and the episodes. ManiSkill's ``BaseEnv._clear`` ends every scene change
    with a full ``gc.collect()`` (to free GPU memory), which would otherwise walk all of them each time;
    frozen, it walks only the envs, their scenes and what came after. Done when nothing is frozen yet (the
    first env of a process), and for a source of over ``FREEZE_EPISODES`` episodes when no other env lives
    (a living env would be frozen with it). What is frozen is never collected as a reference cycle: objects
    the caller holds then and drops later in a cycle stay in memory."""
    if gc.get_freeze_count() and (episodes <= FREEZE_EPISODES or len(_LIVE)):
        return
    load_kernels()
    gc.collect()
    gc.freeze()


class FreezesLiveObjects:
    """A ``BaseEnv`` mixin: :func:`freeze_live_objects` runs before the env object is made, so the env, its
    scenes and their cycles stay collectable."""

    def __new__(cls, *args, **kwargs):
        episodes = kwargs.get("episodes")  # checked by the env; anything else counts as none here
        freeze_live_objects(len(episodes) if hasattr(episodes, "__len__") else 0)
        env = super().__new__(cls)
        _LIVE.add(env)
        return env
