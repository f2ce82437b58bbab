"""VLFM's detector specs by name: the label its results carry and the observation it reads.

Light on purpose (no torch, no SciPy): the method registry imports it. The detectors themselves are built
by :func:`biovln_ms.perception.detectors.make_detector`.
"""

from __future__ import annotations

#: the detector VLFM uses unless told otherwise: the segmentation net trained on our renders
DEFAULT_DETECTOR = "trained"
#: what VLFM reads with an image detector, and with the GT detector (the segmentation sensor besides)
IMAGE_OBS, GT_OBS = "rgb+depth", "rgb+depth+segmentation"
#: result labels of the shipped detector specs
LABELS = {"trained": "VLFM (learned detector)", "gt": "VLFM (GT detector)"}


def obs_mode(spec: str) -> str:
    """The observation mode VLFM needs with detector ``spec``."""
    return GT_OBS if spec == "gt" else IMAGE_OBS


def label(name: str) -> str:
    """The result label of VLFM with the detector named ``name`` ("VLFM (owlvit:DIR)" for others)."""
    return LABELS.get(name, f"VLFM ({name})")
