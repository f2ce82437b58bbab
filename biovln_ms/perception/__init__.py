"""Perception components for the VLFM baseline: image-text scorers and object detectors (pluggable)."""
