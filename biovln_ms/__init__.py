"""BioVLN-MS: operational-face navigation to laboratory instruments on SAPIEN / ManiSkill3."""

__version__ = "0.1.0"
