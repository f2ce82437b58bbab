"""Robots (ManiSkill's "agents"): importing this registers them with ManiSkill. Policies live beside, in
``biovln_ms.agents`` modules, and never import a robot."""

from biovln_ms.agents.robots import biovln_base  # noqa: F401
