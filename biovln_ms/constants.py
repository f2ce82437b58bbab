"""Platform-wide constants that several modules share (one definition each)."""

#: Radius of the mobile base (m). The navigation geometry, episode generator and robot all use it.
ROBOT_RADIUS = 0.20
#: Thickness of generated walls (m); walls stand outside the rooms' inner floor polygons.
WALL_THICKNESS = 0.10
#: Gap (m) between a table-top instrument's operational face and the edge of its support.
SUPPORT_EDGE_MARGIN = 0.05
#: Version of the procedural scene generator (bump when its output for a seed changes).
SCENE_GENERATOR_VERSION = 2  # 2: wall interior normals fixed (walls stood inside the floor)
