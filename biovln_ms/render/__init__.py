"""SAPIEN rendering helpers (offscreen; CPU lavapipe or GPU)."""
