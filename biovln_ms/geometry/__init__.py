"""Pure geometry (NumPy, shapely and a Numba kernel; no SAPIEN): the three-zone model, layout and
navigation grids, coordinate frames."""
