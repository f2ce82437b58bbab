"""Protocol frontier: the depth-only frontier agent (:class:`~biovln_ms.baselines.frontier.FrontierPolicy`)
given each sub-goal of a lab protocol in turn.

At each sub-goal the agent starts over (an empty map, the goal read once from the goal sensor, which now
points at the new sub-goal), as if a new episode began where the last goal was found; see
:mod:`~biovln_ms.baselines.protocol.chain`. Like the single-goal agent it knows each goal's position, not its
category or the instruction.
"""

from __future__ import annotations

from biovln_ms.baselines.frontier import FrontierParams, FrontierPolicy
from biovln_ms.baselines.protocol.chain import SubgoalChain


class ProtocolFrontierPolicy(SubgoalChain):
    """The frontier agent, reset onto each sub-goal when ``info["subgoal_index"]`` advances."""

    name = "protocol_frontier"

    def __init__(self, params: FrontierParams | None = None) -> None:
        super().__init__(FrontierPolicy(params))
