"""The head camera's shader pack: ManiSkill's "minimal" when colour is observed, else BioVLN-MS's depth-only
pack (``shaders/depth_only``), which writes where each pixel's surface lies and its segmentation id and
shades nothing.

On lavapipe a 640x480 frame's lighting (a loop over the point lights and image-based light lookups per
pixel) is most of its cost; the depth-only pack skips it. Its position arithmetic and its discard of
fully transparent texels are the minimal pack's, so its depth and segmentation pictures are the same bit
for bit (``tests/test_camera_shaders.py``), and so is every trajectory of a policy that reads only them.
"""

from __future__ import annotations

from pathlib import Path

from mani_skill.render.shaders import PREBUILT_SHADER_CONFIGS, ShaderConfig

DEPTH_ONLY_DIR = Path(__file__).with_name("shaders") / "depth_only"

#: the minimal pack's combined picture: position (mm), depth (mm) and segmentation from one texture
_POSITION_SEGMENTATION = "PositionSegmentation"


def head_camera_shader(rgb: bool, normal: bool, albedo: bool) -> ShaderConfig:
    """The shader config of an observation that reads colour (``rgb``), normals or albedo, or neither."""
    if normal or albedo:  # only SAPIEN's default pack renders them
        return PREBUILT_SHADER_CONFIGS["default"]
    minimal = PREBUILT_SHADER_CONFIGS["minimal"]
    if rgb:
        return minimal
    return ShaderConfig(
        shader_pack=str(DEPTH_ONLY_DIR),
        texture_names={_POSITION_SEGMENTATION: minimal.texture_names[_POSITION_SEGMENTATION]},
        texture_transforms={_POSITION_SEGMENTATION: minimal.texture_transforms[_POSITION_SEGMENTATION]},
    )
