"""The head camera's shader pack: ManiSkill's "minimal" when colour is observed (or no picture at all),
SAPIEN's "default" for normals or albedo, and BioVLN-MS's depth-only pack (``shaders/depth_only``) for an
observation of depth and/or segmentation without colour: it writes where each pixel's surface lies and its
segmentation id and shades nothing.

On lavapipe a 640x480 frame's lighting (a loop over the point lights and image-based light lookups per
pixel) is most of its cost; the depth-only pack skips it. Its position arithmetic and its discard of
fully transparent texels are the minimal pack's, and its picture is stored in the minimal pack's format
(int16 millimetres, :func:`use_depth_only_format`), so its depth and segmentation are the same bit for bit
(``tests/test_camera_shaders.py``), and so is every trajectory of a policy that reads only them.
"""

from __future__ import annotations

from pathlib import Path

import sapien
from mani_skill.render.shaders import PREBUILT_SHADER_CONFIGS, ShaderConfig

DEPTH_ONLY_DIR = Path(__file__).with_name("shaders") / "depth_only"

#: the minimal pack's combined picture: position (mm), depth (mm) and segmentation from one texture
_POSITION_SEGMENTATION = "PositionSegmentation"
_INT16_MM = "r16g16b16a16sint"  # the minimal pack's format of that picture


def head_camera_shader(visual) -> ShaderConfig:
    """The shader config of an observation's pictures (``visual``: ManiSkill's ``obs_mode_struct.visual``)."""
    if visual.normal or visual.albedo:  # only SAPIEN's default pack renders them
        return PREBUILT_SHADER_CONFIGS["default"]
    minimal = PREBUILT_SHADER_CONFIGS["minimal"]
    if visual.rgb or not (visual.depth or visual.segmentation or visual.position):
        return minimal  # colour, or no picture observed (render_mode="sensors" still shows colour)
    return ShaderConfig(
        shader_pack=str(DEPTH_ONLY_DIR),
        texture_names={_POSITION_SEGMENTATION: minimal.texture_names[_POSITION_SEGMENTATION]},
        texture_transforms={_POSITION_SEGMENTATION: minimal.texture_transforms[_POSITION_SEGMENTATION]},
    )


def use_depth_only_format() -> None:
    """Store the next cameras' position/segmentation picture as int16 millimetres, as the minimal pack does.

    SAPIEN fixes a camera's picture formats when the camera is made, from a process-wide setting that
    ManiSkill sets only for its own packs; without this a depth-only camera would take whatever the last
    camera made (or ``biovln_ms.render.sapien_utils.new_scene``) left: int32, or float32 read as NaN."""
    sapien.render.set_picture_format(_POSITION_SEGMENTATION, _INT16_MM)
