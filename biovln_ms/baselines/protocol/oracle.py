"""Protocol oracle: the geodesic oracle (:class:`~biovln_ms.baselines.oracle.OraclePolicy`) chained over a lab
protocol's sub-goals (privileged).

Its privileged view follows the current sub-goal, so the oracle is simply re-targeted (a new shortest path
from where it stands) each time ``info["subgoal_index"]`` advances. As the single-goal oracle it is an
empirical upper bound, not 100 %: with 0.25 m steps and 30 deg turns a STOP can land outside a radius.
"""

from __future__ import annotations

from biovln_ms.baselines.oracle import OraclePolicy
from biovln_ms.baselines.protocol.chain import SubgoalChain


class ProtocolOraclePolicy(SubgoalChain):
    """Privileged: the oracle's shortest path to each sub-goal in turn."""

    name = "protocol_oracle"

    def __init__(self) -> None:
        super().__init__(OraclePolicy())
