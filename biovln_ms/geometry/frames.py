"""Coordinate frames: our scenes are Z-up (SAPIEN, ManiSkill, USD here); glTF is Y-up."""

from __future__ import annotations

import numpy as np

#: maps glTF's Y-up points to our Z-up ones: (x, y, z) -> (x, -z, y)
Y_UP_TO_Z_UP = np.array([[1, 0, 0, 0], [0, 0, -1, 0], [0, 1, 0, 0], [0, 0, 0, 1]], float)
#: what writers of glTF apply to our Z-up data
Z_UP_TO_Y_UP = np.linalg.inv(Y_UP_TO_Z_UP)
