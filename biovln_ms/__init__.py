"""BioVLN-MS: operational-face navigation to laboratory instruments on SAPIEN / ManiSkill3.

Importing the package registers its envs with gymnasium (``gym.make("BioVLN-OpFace-v0")``);
ManiSkill itself is imported on the first ``gym.make``. Your own variants, measures, methods, sensors,
templates and instruments register from your code (:mod:`biovln_ms.plugins`, the extending guide).
"""

from biovln_ms.plugins import load_plugins
from biovln_ms.registration import register_lazily, register_variant

__version__ = "0.1.0"

__all__ = ["load_plugins", "register_variant"]

register_lazily()
