"""Protocol VLFM: VLFM (:class:`~biovln_ms.baselines.vlfm.VLFMPolicy`, the shipped trained detector by
default) given each sub-goal's category in turn.

At each sub-goal the agent starts over (empty frontier, value and object maps) with the category the
``objectgoal`` sensor now names, as if a new episode began where the last goal was found; see
:mod:`~biovln_ms.baselines.protocol.chain`. Like the single-goal agent it is never told a goal's position, and
it does not read the instruction: which instance of a category is meant is not known to it, so it stops at
the first one it detects.
"""

from __future__ import annotations

from biovln_ms.baselines.protocol.chain import SubgoalChain
from biovln_ms.baselines.vlfm import VLFMPolicy
from biovln_ms.perception.detector_specs import DEFAULT_DETECTOR


class ProtocolVLFMPolicy(SubgoalChain):
    """VLFM, reset onto each sub-goal's category when ``info["subgoal_index"]`` advances."""

    name = "protocol_vlfm"

    def __init__(
        self, detector=DEFAULT_DETECTOR, scorer="default", detect_every: int = 5, score_every: int = 1
    ) -> None:
        every = dict(detect_every=detect_every, score_every=score_every)
        super().__init__(VLFMPolicy(detector=detector, scorer=scorer, **every))
