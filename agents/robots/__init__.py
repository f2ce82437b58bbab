"""Robots (ManiSkill's "agents"): importing this registers them with ManiSkill. The policies live in
``biovln_ms.baselines`` and never import a robot."""

from mani_skill.agents.base_agent import BaseAgent

from biovln_ms.agents.robots.biovln_base import BioVLNBase
from biovln_ms.agents.robots.fetch_nav import FetchNav

#: the agent of each robot of ``biovln_ms.robot_specs.ROBOTS`` (the task's ``robot_uids``)
NAV_AGENTS: dict[str, type[BaseAgent]] = {BioVLNBase.robot_id: BioVLNBase, FetchNav.robot_id: FetchNav}
