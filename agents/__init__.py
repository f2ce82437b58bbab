"""Robots of BioVLN-MS and their controllers, ManiSkill's "agents" (installed as ``biovln_ms.agents``).

The navigation policies that drive them live in :mod:`biovln_ms.baselines`: a policy sees observations,
never a robot, so the two share no code."""
