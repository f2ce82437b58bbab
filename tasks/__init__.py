"""ManiSkill tasks of BioVLN-MS (installed as ``biovln_ms.tasks``). Importing this registers them."""

from biovln_ms.tasks import lab_scene_env, nav_env, variants  # noqa: F401
