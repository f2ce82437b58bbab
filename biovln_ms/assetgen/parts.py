"""Mesh parts with materials, assembled into an origin-centred asset.

Builders work in a canonical frame: the operational face looks along -Y, width runs along X,
depth along Y, Z is up, and the bounding box is centred on the origin. ``Kit.scene`` turns the
parts to the catalog's model-space face (Eq. 3) and returns a trimesh Scene ready for GLB export.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import trimesh
from PIL import Image
from trimesh.visual.material import PBRMaterial
from trimesh.visual.texture import TextureVisuals

from biovln_ms.assetgen import textures as tx
from biovln_ms.geometry.zones import yaw_facing

CANONICAL_FACE = (0.0, -1.0)

# Per face of an axis-aligned box: (outward axis, sign, u axis, v axis).
_BOX_FACES = [
    (0, +1, 1, 2),
    (0, -1, 1, 2),
    (1, +1, 0, 2),
    (1, -1, 0, 2),
    (2, +1, 0, 1),
    (2, -1, 0, 1),
]


@dataclass
class Material:
    """A PBR material; ``texture`` tiles every ``tile`` metres (or stretches once when tile is None).
    With ``face`` the texture is a picture of a box's -Y face and the other faces continue its edges.
    An RGBA texture makes it see-through (glTF alphaMode BLEND), or, when its alpha is only 0 or 255,
    cut out (MASK: holes where decals sit in the same plane). ``normal`` and ``emission`` are the
    normal and emission maps."""

    name: str
    color: tuple[float, float, float, float] = (0.8, 0.8, 0.8, 1.0)
    texture: Image.Image | None = None
    tile: float | None = 0.25
    metallic: float = 0.0
    roughness: float = 0.6
    normal: Image.Image | None = None
    emission: Image.Image | None = None
    face: bool = False
    _pbr: PBRMaterial | None = field(default=None, repr=False)

    def pbr(self) -> PBRMaterial:
        if self._pbr is None:
            extra: dict = {}
            if self.normal is not None:
                extra["normalTexture"] = self.normal
            if self.emission is not None:
                extra.update(emissiveTexture=self.emission, emissiveFactor=[1.0, 1.0, 1.0])
            if self.texture is not None and self.texture.mode == "RGBA":
                alpha = set(np.unique(np.asarray(self.texture)[..., 3]).tolist())
                extra["alphaMode"] = "MASK" if alpha <= {0, 255} else "BLEND"
            self._pbr = PBRMaterial(
                name=self.name,
                baseColorFactor=[int(round(255 * c)) for c in self.color],
                baseColorTexture=self.texture,
                metallicFactor=self.metallic,
                roughnessFactor=self.roughness,
                **extra,
            )
        return self._pbr


def _uv_box(extents: np.ndarray, tile: float | None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A box with 24 vertices and per-face UVs (so textures map without seams smearing)."""
    verts, faces, uvs = [], [], []
    half = extents / 2.0
    for axis, sign, ua, va in _BOX_FACES:
        corners = []
        for du, dv in ((-1, -1), (1, -1), (1, 1), (-1, 1)):
            p = np.zeros(3)
            p[axis] = sign * half[axis]
            p[ua] = du * half[ua]
            p[va] = dv * half[va]
            corners.append(p)
        base = len(verts)
        verts.extend(corners)
        # Winding so the normal points along sign * axis.
        n = np.cross(corners[1] - corners[0], corners[2] - corners[0])
        if np.dot(n, np.eye(3)[axis] * sign) > 0:
            faces.extend([[base, base + 1, base + 2], [base, base + 2, base + 3]])
        else:
            faces.extend([[base, base + 2, base + 1], [base, base + 3, base + 2]])
        su = extents[ua] / tile if tile else 1.0
        sv = extents[va] / tile if tile else 1.0
        uvs.extend([[0.0, 0.0], [su, 0.0], [su, sv], [0.0, sv]])
    return np.array(verts), np.array(faces), np.array(uvs)


def _uv_face(verts: np.ndarray, extents: np.ndarray) -> np.ndarray:
    """UVs of a ``_uv_box`` whose texture pictures its -Y face: every vertex at its (x, z) on that face,
    the other faces clamped a little inside the picture (so the sides repeat its edge pixels, clear of
    any cut-out)."""
    uv = (verts[:, [0, 2]] + extents[[0, 2]] / 2) / extents[[0, 2]]
    out = np.clip(uv, 0.004, 0.996)
    k = 4 * _BOX_FACES.index((1, -1, 0, 2))
    out[k : k + 4] = uv[k : k + 4]
    return out


def _uv_cylinder(verts: np.ndarray, height: float, tile: float | None) -> np.ndarray:
    """UVs of a Z-axis cylinder without new vertices: u is the arc length from the -Y side (mirrored
    on the +X and -X halves, so there is no seam), v the height."""
    theta = np.abs(np.arctan2(verts[:, 0], -verts[:, 1]))
    radius = float(np.hypot(verts[:, 0], verts[:, 1]).max())
    z = verts[:, 2] + height / 2
    if tile:
        return np.stack([theta * radius / tile, z / tile], axis=1)
    return np.stack([theta / np.pi, z / height], axis=1)


def _mesh_with(
    material: Material, verts: np.ndarray, faces: np.ndarray, uv: np.ndarray | None
) -> trimesh.Trimesh:
    mesh = trimesh.Trimesh(vertices=verts, faces=faces, process=False)
    mesh.visual = TextureVisuals(uv=uv, material=material.pbr())
    return mesh


class Kit:
    """Accumulates named parts of one asset in the canonical frame."""

    def __init__(self, name: str, width: float, depth: float, height: float) -> None:
        self.name = name
        self.W, self.D, self.H = width, depth, height
        self.parts: list[tuple[str, trimesh.Trimesh]] = []
        self._materials: dict[str, Material] = {}

    # Frame helpers: canonical bounds.
    @property
    def front(self) -> float:
        return -self.D / 2

    @property
    def back(self) -> float:
        return self.D / 2

    @property
    def bottom(self) -> float:
        return -self.H / 2

    @property
    def top(self) -> float:
        return self.H / 2

    def seed(self, *keys: str) -> int:
        return tx.seed_for(self.name, *keys)

    def material(self, key: str, **kwargs) -> Material:
        """A material shared by every part that names the same key."""
        if key not in self._materials:
            self._materials[key] = Material(name=f"{self.name}_{key}", **kwargs)
        return self._materials[key]

    def box(
        self, name: str, size: tuple[float, float, float], center: tuple[float, float, float], mat: Material
    ) -> None:
        ext = np.asarray(size, float)
        v, f, uv = _uv_box(ext, mat.tile if mat.texture is not None else 1.0)
        if mat.face:
            uv = _uv_face(v, ext)
        self.parts.append(
            (name, _mesh_with(mat, v + np.asarray(center, float), f, uv if mat.texture is not None else None))
        )

    def box_span(
        self, name: str, lo: tuple[float, float, float], hi: tuple[float, float, float], mat: Material
    ) -> None:
        lo_a, hi_a = np.asarray(lo, float), np.asarray(hi, float)
        self.box(name, tuple(hi_a - lo_a), tuple((hi_a + lo_a) / 2), mat)

    def cylinder(
        self,
        name: str,
        radius: float,
        height: float,
        center: tuple[float, float, float],
        mat: Material,
        axis: str = "z",
        sections: int = 32,
        scale_xy: tuple[float, float] = (1.0, 1.0),
        top_uv: bool = False,
    ) -> None:
        """A cylinder; its texture wraps round it, or with ``top_uv`` is projected from above (a lid seen
        from above: the cap gets an even texture, the rim its edge pixels as moulded ribs)."""
        m = trimesh.creation.cylinder(radius=radius, height=height, sections=sections)
        m.apply_scale([scale_xy[0], scale_xy[1], 1.0])
        uv = None
        if mat.texture is not None:
            uv = (
                m.vertices[:, :2] / (mat.tile or 1.0)
                if top_uv
                else _uv_cylinder(m.vertices, height, mat.tile)
            )
        if axis == "x":
            m.apply_transform(trimesh.transformations.rotation_matrix(math.pi / 2, [0, 1, 0]))
        elif axis == "y":
            m.apply_transform(trimesh.transformations.rotation_matrix(math.pi / 2, [1, 0, 0]))
        m.apply_translation(center)
        self.parts.append((name, _mesh_with(mat, m.vertices, m.faces, uv)))

    def decal(
        self,
        name: str,
        image: Image.Image | tx.Surface,
        center: tuple[float, float, float],
        width: float,
        height: float,
        facing: str = "-Y",
    ) -> None:
        """A flat textured quad (label, display, keypad) on a surface facing ``facing``."""
        s = image if isinstance(image, tx.Surface) else tx.Surface(image)
        mat = self.material(
            f"decal_{name}",
            color=(1.0, 1.0, 1.0, 1.0),
            texture=s.albedo,
            normal=s.normal,
            emission=s.emission,
            tile=None,
            roughness=0.25 if s.emission is not None else 0.45,
        )
        hw, hh = width / 2, height / 2
        c = np.asarray(center, float)
        if facing == "-Y":
            v = [[-hw, 0, -hh], [hw, 0, -hh], [hw, 0, hh], [-hw, 0, hh]]
        elif facing == "+Z":
            v = [[-hw, -hh, 0], [hw, -hh, 0], [hw, hh, 0], [-hw, hh, 0]]
        elif facing == "+Y":
            v = [[hw, 0, -hh], [-hw, 0, -hh], [-hw, 0, hh], [hw, 0, hh]]
        else:
            raise ValueError(f"decal facing must be -Y, +Y or +Z, got {facing}")
        verts = np.asarray(v, float) + c
        faces = np.array([[0, 1, 2], [0, 2, 3]])
        n = np.cross(verts[1] - verts[0], verts[2] - verts[0])
        want = {"-Y": [0, -1, 0], "+Y": [0, 1, 0], "+Z": [0, 0, 1]}[facing]
        if np.dot(n, want) < 0:
            faces = faces[:, ::-1]
        uv = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], float)
        self.parts.append((name, _mesh_with(mat, verts, faces, uv)))

    def scene(self, model_face: tuple[float, float]) -> trimesh.Scene:
        """All parts turned so the canonical -Y face becomes ``model_face`` (Eq. 3)."""
        yaw = yaw_facing(CANONICAL_FACE, model_face)
        rot = trimesh.transformations.rotation_matrix(yaw, [0, 0, 1])
        # Snap tiny floating-point residue of the 90-degree rotations so output is stable.
        rot = np.round(rot, 12)
        scene = trimesh.Scene()
        for name, mesh in self.parts:
            m = mesh.copy()
            m.apply_transform(rot)
            scene.add_geometry(m, node_name=f"{self.name}.{name}", geom_name=f"{self.name}.{name}")
        return scene
