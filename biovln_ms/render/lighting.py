"""Lighting presets of lab scenes: one table, applied by the scene builder.

``fast`` is the default and the lighting of every released result (ambient, an unshadowed key light and
one unshadowed point light per room). ``quality`` lights each room with
shadow-casting ceiling fixtures (SAPIEN's rasteriser, cube-map shadows of point lights, which the
"minimal" camera shader of the head camera also samples), a lower ambient term and a weak directional fill,
so furniture and instruments cast shadows on the floor and walls.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from biovln_ms.errors import BioVLNError


@dataclass(frozen=True)
class LightingPreset:
    """Ambient colour, a directional key/fill light and ceiling fixtures derived from the scene's rooms."""

    ambient: tuple[float, float, float]
    key_direction: tuple[float, float, float]
    key_color: tuple[float, float, float]
    fixture_color: tuple[float, float, float]  # per fixture (a room's total is spread over its fixtures)
    fixture_drop: float = 0.3  # m below the ceiling
    fixture_spacing: float | None = None  # m between fixtures of a grid; None: one fixture per room
    shadows: bool = False  # fixtures cast shadows
    shadow_map_size: int = 256  # per cube face: shadow passes dominate a lavapipe frame
    shadow_near: float = 0.1
    shadow_far: float = 12.0
    max_fixtures: int = 10  # SAPIEN's shaders take at most 10 point lights per scene


LIGHTING: dict[str, LightingPreset] = {
    "fast": LightingPreset(
        ambient=(0.45, 0.45, 0.45),
        key_direction=(0.3, 0.5, -1.0),
        key_color=(0.7, 0.7, 0.68),
        fixture_color=(2.0, 2.0, 1.9),
    ),
    "quality": LightingPreset(
        ambient=(0.22, 0.22, 0.24),
        key_direction=(0.3, 0.5, -1.0),
        key_color=(0.25, 0.25, 0.26),
        fixture_color=(4.2, 4.1, 3.9),
        fixture_spacing=4.0,
        shadows=True,
        shadow_map_size=256,
    ),
}


class LightingError(BioVLNError):
    """An unknown lighting preset."""


def lighting_preset(name: str) -> LightingPreset:
    """The preset called ``name``; a one-line error listing the presets otherwise."""
    if name not in LIGHTING:
        raise LightingError(
            f"unknown lighting preset '{name}'", field="lighting", fix=f"use one of: {', '.join(LIGHTING)}"
        )
    return LIGHTING[name]


def fixture_positions(room, preset: LightingPreset) -> list[tuple[float, float, float]]:
    """Ceiling fixtures of one room: its centre, or a grid ``fixture_spacing`` apart over its bounding box
    (cells whose centre is outside the room's polygon left out), ``fixture_drop`` below the ceiling."""
    xy = np.asarray(room.polygon, float)
    z = room.height - preset.fixture_drop
    if preset.fixture_spacing is None:
        return [(*map(float, xy.mean(0)), z)]
    lo, hi = xy.min(0), xy.max(0)
    n = np.maximum(1, np.round((hi - lo) / preset.fixture_spacing)).astype(int)
    cells = [lo + (hi - lo) * (np.array([i, j]) + 0.5) / n for i in range(n[0]) for j in range(n[1])]
    try:
        import shapely

        poly = shapely.Polygon(xy)
        inside = [c for c in cells if poly.contains(shapely.Point(c))]
        cells = inside or [xy.mean(0)]
    except ImportError:  # pragma: no cover - shapely is a dependency
        pass
    return [(float(c[0]), float(c[1]), z) for c in cells]


def apply_lighting(
    scene, spec, lighting: str = "fast", *, key_shadow: bool = False, scene_idxs: list[int] | None = None
) -> None:
    """Add the preset's lights for ``spec``'s rooms to ``scene`` (sapien.Scene or ManiSkillScene)."""
    p = lighting_preset(lighting)
    kw = {} if scene_idxs is None else {"scene_idxs": scene_idxs}
    scene.set_ambient_light(list(p.ambient))
    scene.add_directional_light(list(p.key_direction), list(p.key_color), shadow=key_shadow, **kw)
    rooms = [r for r in spec.rooms if r.kind == "room"]
    fixtures = [(r, f) for r in rooms for f in fixture_positions(r, p)]
    if len(fixtures) > p.max_fixtures:  # too many for the shaders: one per room
        fixtures = [(r, fixture_positions(r, LIGHTING["fast"])[0]) for r in rooms]
    per_room = {id(r): sum(1 for q, _ in fixtures if q is r) for r in rooms}
    for r, pos in fixtures:
        color = list(p.fixture_color)
        if p.fixture_spacing is not None:  # a room's light stays the same whatever its grid
            color = [c * _grid_scale(per_room[id(r)]) for c in color]
        if p.shadows:
            scene.add_point_light(
                list(pos),
                color,
                shadow=True,
                shadow_near=p.shadow_near,
                shadow_far=p.shadow_far,
                shadow_map_size=p.shadow_map_size,
                **kw,
            )
        else:
            scene.add_point_light(list(pos), color, **kw)


def _grid_scale(n: int) -> float:
    """Fixtures of a grid are dimmer than a lone one, but less than 1/n (they light the room more evenly)."""
    return 1.0 / np.sqrt(n)
