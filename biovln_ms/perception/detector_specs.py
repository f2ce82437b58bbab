"""VLFM's detector specs by name: the label its results carry, the observation it reads, and whether it
can run here (:func:`check_spec`, before any env is built).

Light on purpose (no torch, no SciPy): the method registry imports it. The detectors themselves are built
by :func:`biovln_ms.perception.detectors.make_detector`.
"""

from __future__ import annotations

from biovln_ms.perception import segmenter
from biovln_ms.perception.scorers import PerceptionError, check_saved_model

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


def parse_spec(spec: str) -> tuple[str, str | None]:
    """(kind, argument) of a detector spec: ``("gt", None)``, ``("trained", None)`` (the shipped weights),
    ``("trained", FILE)`` or ``("owlvit", DIR)``; a one-line error for anything else."""
    if spec in (GT_SPEC, TRAINED_SPEC):
        return spec, None
    for kind in (TRAINED_SPEC, "owlvit"):
        if isinstance(spec, str) and spec.startswith(f"{kind}:"):
            return kind, spec.removeprefix(f"{kind}:")
    raise PerceptionError(
        f"unknown detector '{spec}'",
        field="detector",
        fix="use 'gt', 'trained', 'trained:/path/to/detector.safetensors' or 'owlvit:/path/to/saved/owlvit'",
    )


def check_spec(spec: str) -> None:
    """A one-line error, before any env is built, for a spec
    :func:`~biovln_ms.perception.detectors.make_detector` cannot build: an unknown name, weights whose header
    does not read for this catalog, a folder without a saved OWL-ViT."""
    kind, arg = parse_spec(spec)
    if kind == TRAINED_SPEC:
        segmenter.read_header(arg if arg is not None else segmenter.shipped_weights())
    elif kind == "owlvit":
        check_saved_model(arg, "detector", "OWL-ViT")
