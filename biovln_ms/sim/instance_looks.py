"""Per-instance looks at scene-build time: each placed instrument or piece of furniture
gets the textures of its :class:`~biovln_ms.assetgen.variation.Variant` (drawn from the scene's name and
seed and the object's id), so two incubators in one lab differ in labels, setpoints, wear and colour.

Only textures change: the actor keeps the shipped GLB's meshes. SAPIEN merges a GLB's primitives by
material into the parts of one render shape and keeps no material names, so a part is matched to its
GLB material by the part's bounding box (unique per material in every shipped asset; tested).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

import numpy as np
import sapien
from PIL import Image

from biovln_ms.assetgen import textures as tx
from biovln_ms.assetgen.generate import load_glb
from biovln_ms.assetgen.instruments import LIVE_DECALS
from biovln_ms.assetgen.variation import Variant, restyle

#: material bounds are compared at this resolution (m)
BOUNDS_DECIMALS = 4


def bounds_key(lo, hi) -> tuple[float, ...]:
    """A material's (or a render part's) bounding box as a hashable key."""
    return tuple(np.round(np.concatenate([lo, hi]).astype(float), BOUNDS_DECIMALS).tolist())


#: a variant repaints the painted and moulded surfaces with a face at least this large (m^2): bodies,
#: doors, lids (not decals, metals, glass or small fittings)
PAINTWORK_MIN_AREA = 0.03


@dataclass(frozen=True)
class AssetMaterials:
    """Of one GLB: each material's name by the key of its bounding box, and the textures a variant
    repaints (:data:`PAINTWORK_MIN_AREA`)."""

    names: dict[tuple[float, ...], str]
    paintwork: dict[str, Image.Image]


@lru_cache(maxsize=None)
def asset_materials(path: Path) -> AssetMaterials:
    """The materials of the GLB at ``path`` (read once per process)."""
    scene = load_glb(path)
    lo: dict[str, np.ndarray] = {}
    hi: dict[str, np.ndarray] = {}
    paintwork = {}
    for node in scene.graph.nodes_geometry:
        transform, geom = scene.graph[node]
        mesh = scene.geometry[geom]
        mat = mesh.visual.material
        v = mesh.vertices @ transform[:3, :3].T + transform[:3, 3]
        lo[mat.name] = np.minimum(lo.get(mat.name, v.min(0)), v.min(0))
        hi[mat.name] = np.maximum(hi.get(mat.name, v.max(0)), v.max(0))
        tex = getattr(mat, "baseColorTexture", None)
        if (
            tex is not None
            and tex.mode == "RGB"
            and "_decal_" not in mat.name
            and (mat.metallicFactor or 0.0) < 0.5
        ):
            paintwork[mat.name] = tex
    for name in list(paintwork):
        e = np.sort(hi[name] - lo[name])
        if e[1] * e[2] < PAINTWORK_MIN_AREA:
            del paintwork[name]
    return AssetMaterials({bounds_key(lo[n], hi[n]): n for n in lo}, paintwork)


Pictures = dict[str, tuple[np.ndarray, np.ndarray | None]]


def _rgba(img: Image.Image | np.ndarray) -> np.ndarray:
    arr = np.asarray(img.convert("RGBA") if isinstance(img, Image.Image) else img, np.uint8)
    arr = np.ascontiguousarray(arr)
    arr.flags.writeable = False
    return arr


@lru_cache(maxsize=32)
def paintwork_pictures(path: Path, tint: tuple[float, float, float], wear: float) -> Pictures:
    """Material name -> repainted base colour (RGBA) of one paint look (a bounded set: made once)."""
    return {
        name: (_rgba(restyle(tex, tint, wear, name, face="_art_" in name)), None)
        for name, tex in asset_materials(path).paintwork.items()
    }


@lru_cache(maxsize=64)
def variant_pictures(category: str, path: Path, variant: Variant) -> Pictures:
    """Material name -> (base colour, emission or None) RGBA pictures of ``category`` in ``variant``."""
    out = dict(paintwork_pictures(path, variant.tint, variant.wear))
    for decal, draw in LIVE_DECALS.get(category, {}).items():
        s = draw(variant)
        s = s if isinstance(s, tx.Surface) else tx.Surface(s)
        out[f"{category}_decal_{decal}"] = (
            _rgba(s.albedo),
            _rgba(s.emission) if s.emission is not None else None,
        )
    return out


def apply_variant(actor, category: str, path: Path, variant: Variant, uploads: dict | None = None) -> int:
    """Give ``actor`` (a sapien.Entity or a ManiSkill Actor, built from ``path``) the textures of
    ``variant``; returns the number of render parts changed.

    The pictures are cached; the textures are made per scene (a cached texture would hold SAPIEN's render
    device, and a process may create another one later, as ManiSkill does for its envs). ``uploads``
    shares them between the objects of one scene (pictures shown by several are uploaded once)."""
    names = asset_materials(path).names
    pictures = variant_pictures(category, path, variant)
    uploads = {} if uploads is None else uploads

    def texture(arr: np.ndarray) -> sapien.render.RenderTexture2D:
        if id(arr) not in uploads:  # the cached pictures live as long as ``uploads`` is used
            uploads[id(arr)] = (
                sapien.render.RenderTexture2D(arr, "R8G8B8A8Unorm", 1, "linear", "repeat", True),
                arr,
            )
        return uploads[id(arr)][0]

    changed = 0
    for entity in getattr(actor, "_objs", [actor]):
        body = entity.find_component_by_type(sapien.render.RenderBodyComponent)
        for shape in body.render_shapes if body is not None else ():
            for part in shape.parts:
                v = part.get_vertices()
                found = pictures.get(names.get(bounds_key(v.min(0), v.max(0)), ""))
                if found is None:
                    continue
                albedo, emission = found
                part.material.set_base_color_texture(texture(albedo))
                if emission is not None:
                    part.material.set_emission_texture(texture(emission))
                changed += 1
    return changed
