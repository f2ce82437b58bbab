"""Platform-wide constants that several modules share (one definition each)."""

from biovln_ms.robot_specs import DEFAULT_ROBOT, ROBOTS

#: Footprint radius (m) of the default robot (``biovln_ms.robot_specs``): the default of the navigation
#: geometry, the scene and episode generators and the datasets; another robot's comes from its ``ROBOTS`` row.
ROBOT_RADIUS = ROBOTS[DEFAULT_ROBOT].footprint_radius
#: A depth point lower than this (m) above the floor is the floor: the frontier map's obstacle cut and the
#: image detectors' floor filter.
FLOOR_HEIGHT = 0.05
#: Thickness of generated walls (m); walls stand outside the rooms' inner floor polygons.
WALL_THICKNESS = 0.10
#: Gap (m) between a table-top instrument's operational face and the edge of its support.
SUPPORT_EDGE_MARGIN = 0.05
#: Version of the procedural scene generator (bump when its output for a seed changes).
SCENE_GENERATOR_VERSION = 2  # 2: wall interior normals fixed (walls stood inside the floor)
#: The number of visits (goals) K a lab protocol may have: the range ``BioVLN-Protocol-v0`` episodes use.
MIN_VISITS, MAX_VISITS = 2, 5
#: Timesteps between the atomic checkpoints ``biovln-ms train`` writes (``RLConfig.checkpoint_every``).
CHECKPOINT_EVERY = 50_000
