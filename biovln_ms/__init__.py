"""BioVLN-MS: operational-face navigation to laboratory instruments on SAPIEN / ManiSkill3.

Importing the package registers its envs with gymnasium (``gym.make("BioVLN-OpFace-v0")``);
ManiSkill itself is imported on the first ``gym.make``.
"""

from biovln_ms.registration import register_lazily

__version__ = "0.1.0"

register_lazily()
