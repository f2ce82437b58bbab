"""Pure geometry (numpy/shapely, no SAPIEN): the three-zone model, layout and navigation grids."""
