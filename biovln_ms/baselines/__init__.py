"""The navigation policies (baselines) of BioVLN-MS, one module or sub-package per method.

Every policy implements :class:`~biovln_ms.baselines.policy.Policy` and runs from the env's observations
and info alone (the oracles also get a read-only privileged view through ``EpisodeInfo``); none imports the
simulator, the tasks or the robots. :mod:`biovln_ms.eval.methods` names them for evaluation.
:mod:`~biovln_ms.baselines.frontier` holds the map, planner, controller and pose estimators that the other
depth-based methods reuse; :mod:`~biovln_ms.baselines.protocol` the agents of the lab-protocol tasks.
"""
