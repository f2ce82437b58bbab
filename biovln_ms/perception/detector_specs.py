"""VLFM's detector specs by name: the label its results carry and the observation it reads.

Light on purpose (no torch, no SciPy): the method registry imports it. The detectors themselves are built
by :func:`biovln_ms.perception.detectors.make_detector`.
"""

from __future__ import annotations

#: the spec of the segmentation net trained on our renders (``trained:FILE``: other weights), VLFM's default
TRAINED_SPEC = "trained"
DEFAULT_DETECTOR = TRAINED_SPEC
#: what VLFM reads with an image detector, and with the GT detector (the segmentation sensor besides)
IMAGE_OBS, GT_OBS = "rgb+depth", "rgb+depth+segmentation"
#: the GT detector's spec, and the name the built detector carries (records' ``policy_stats.detector``)
GT_SPEC, GT_NAME = "gt", "gt-segmentation"
#: result labels of the shipped detectors, by spec and by built name
LABELS = {
    TRAINED_SPEC: "VLFM (learned detector)",
    GT_SPEC: "VLFM (GT detector)",
    GT_NAME: "VLFM (GT detector)",
}


def name_of(detector) -> str:
    """A detector spec as given, or a built detector's ``name``."""
    return detector if isinstance(detector, str) else getattr(detector, "name", type(detector).__name__)


def obs_mode(detector) -> str:
    """The observation mode VLFM needs with ``detector`` (a spec or a built detector)."""
    return GT_OBS if name_of(detector) in (GT_SPEC, GT_NAME) else IMAGE_OBS


def label(detector) -> str:
    """The result label of VLFM with ``detector`` ("VLFM (owlvit:DIR)" for others)."""
    name = name_of(detector)
    return LABELS.get(name, f"VLFM ({name})")
