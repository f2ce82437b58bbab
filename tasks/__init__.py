"""ManiSkill tasks of BioVLN-MS (installed as ``biovln_ms.tasks``)."""
