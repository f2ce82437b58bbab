"""Robots and navigation policies of BioVLN-MS (installed as ``biovln_ms.agents``)."""
