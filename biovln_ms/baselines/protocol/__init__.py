"""Agents of the lab-protocol tasks (``BioVLN-Protocol-v0``): the single-goal baselines chained over a
protocol's ordered sub-goals (:mod:`~biovln_ms.baselines.protocol.chain`), and an agent that reads the
instruction instead of the goal sensors (:mod:`~biovln_ms.baselines.protocol.language`)."""
