"""Reproducible procedural GLB assets (trimesh): instruments, furniture and room-shell pieces."""
