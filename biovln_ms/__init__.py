"""BioVLN-MS: operational-face navigation to laboratory instruments on SAPIEN / ManiSkill3.

Importing the package registers its envs with gymnasium (``gym.make("BioVLN-OpFace-v0")``);
ManiSkill itself is imported on the first ``gym.make``.
"""

__version__ = "0.1.0"


def _register() -> None:
    from biovln_ms.registration import register_lazily

    register_lazily()


_register()
