"""LSAT exporters (paper §3.4, appendix "Available Supplementary Materials"): BioVLN goal JSON, the LSAT
intermediate format, and USD for Isaac Sim (``usd-core``). All three read a validated scene spec, so
procedural and designer-authored scenes export alike; every file is written atomically.

Goal JSON (``biovln-goals``, version 1)::

    {"format": "biovln-goals", "version": 1, "scene": str, "frame": "z_up", "units": "m",
     "goals": [{"object_id", "category", "position": [x, y, 0], "face": [fx, fy], "facing_yaw": rad,
                "success_radius", "source": "marker" | "eq1"}]}

LSAT intermediate format (``lsat-scene``, version 1): the scene as LSAT's layers hand it over —
rooms (polygon, height), and per object its pose (centre, yaw, size, placement, support), operational
face, the three zones as polygons (Zone 1 body, Zone 2 clearance, Zone 3 operation area) and its goal
with the strategy that produced it (1: marker, 2: geometry + Eq. 1)::

    {"format": "lsat-scene", "version": 1, "scene": str, "frame": "z_up", "units": "m",
     "rooms": [{"id", "kind", "polygon": [[x, y], ...], "height"}],
     "objects": [{"id", "category", "node", "center": [x, y, z], "yaw", "size": [w, d, h], "placement",
                  "support", "face": [fx, fy] | null,
                  "zones": {"zone1": [[x, y], ...], "zone2": ..., "zone3": ...},
                  "goal": {"position": [x, y], "success_radius", "strategy": 1 | 2} | null}],
     "coverage": {...}}

USD: ``/World`` (Z up, metres) with ``/World/Room`` (the room shell meshes), ``/World/Instruments/<id>``
Xforms holding the instrument's triangle meshes, with ``biovln:category``, ``biovln:id`` and
``biovln:isGoal`` attributes, and ``/World/Goals/<id>_goal`` Xforms at the goals with
``biovln:category``, ``biovln:objectId``, ``biovln:successRadius`` and ``biovln:source``.
"""

from __future__ import annotations

import json
import math
import re
import tempfile
from pathlib import Path

import numpy as np

from biovln_ms.errors import BioVLNError
from biovln_ms.io_utils import atomic_write_bytes, atomic_write_text
from biovln_ms.scene.export_glb import assemble
from biovln_ms.scene.spec import SceneSpec


def _r(v, nd: int = 5):
    return [round(float(x), nd) + 0.0 for x in v]  # + 0.0: no negative zeros


def _goal_source(o) -> str:
    return "marker" if o.goal_source == "marker" else "eq1"


def goal_json(spec: SceneSpec) -> dict:
    goals = []
    for o in spec.goal_objects():
        fx, fy = o.face
        goals.append(
            {
                "object_id": o.id,
                "category": o.category,
                "position": [*_r(o.goal), 0.0],
                "face": _r(o.face),
                "facing_yaw": round(math.atan2(-fy, -fx), 6),
                "success_radius": o.success_radius,
                "source": _goal_source(o),
            }
        )
    return {
        "format": "biovln-goals",
        "version": 1,
        "scene": spec.name,
        "frame": "z_up",
        "units": "m",
        "goals": goals,
    }


def lsat_json(spec: SceneSpec, report=None) -> dict:
    nodes = {i["id"]: i["node"] for i in report.instruments} if report is not None else {}
    objects = []
    for o in spec.objects():
        p = o.placed()
        zones = {"zone1": _poly(p.zone1()), "zone2": _poly(p.zone2())}
        goal = None
        if o.is_goal:
            zones["zone3"] = _poly(p.zone3())
            goal = {
                "position": _r(o.goal),
                "success_radius": o.success_radius,
                "strategy": 1 if o.goal_source == "marker" else 2,
            }
        objects.append(
            {
                "id": o.id,
                "category": o.category,
                "node": nodes.get(o.id),
                "center": _r(o.position),
                "yaw": round(o.yaw, 6),
                "size": _r(o.size),
                "placement": o.placement,
                "support": o.support,
                "face": _r(o.face) if o.face is not None else None,
                "zones": zones,
                "goal": goal,
            }
        )
    return {
        "format": "lsat-scene",
        "version": 1,
        "scene": spec.name,
        "frame": "z_up",
        "units": "m",
        "rooms": [
            {"id": r.id, "kind": r.kind, "polygon": [_r(v) for v in r.polygon], "height": r.height}
            for r in spec.rooms
        ],
        "objects": objects,
        "coverage": report.coverage() if report is not None else None,
    }


def _poly(poly) -> list[list[float]]:
    return [_r(c) for c in list(poly.exterior.coords)[:-1]]


def _prim_name(s: str) -> str:
    s = re.sub(r"[^A-Za-z0-9_]", "_", s)
    return s if s and not s[0].isdigit() else f"_{s}"


def write_usd(spec: SceneSpec, out: str | Path) -> Path:
    """A USD stage of the scene (``.usda`` text or ``.usd``/``.usdc`` binary, by suffix)."""
    try:
        from pxr import Gf, Sdf, Usd, UsdGeom, Vt
    except ImportError:
        raise BioVLNError("USD export needs usd-core", field="usd", fix="pip install usd-core") from None

    out = Path(out)
    scene = assemble(spec)
    objects = {o.id: o for o in spec.objects()}
    with tempfile.TemporaryDirectory() as tmp:
        tmp_path = Path(tmp) / f"stage{out.suffix or '.usda'}"
        stage = Usd.Stage.CreateNew(str(tmp_path))
        UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
        UsdGeom.SetStageMetersPerUnit(stage, 1.0)
        world = UsdGeom.Xform.Define(stage, "/World")
        stage.SetDefaultPrim(world.GetPrim())
        UsdGeom.Xform.Define(stage, "/World/Room")
        UsdGeom.Xform.Define(stage, "/World/Instruments")
        UsdGeom.Xform.Define(stage, "/World/Goals")
        for o in spec.objects():
            x = UsdGeom.Xform.Define(stage, f"/World/Instruments/{_prim_name(o.id)}")
            prim = x.GetPrim()
            prim.CreateAttribute("biovln:id", Sdf.ValueTypeNames.String).Set(o.id)
            prim.CreateAttribute("biovln:category", Sdf.ValueTypeNames.String).Set(o.category)
            prim.CreateAttribute("biovln:isGoal", Sdf.ValueTypeNames.Bool).Set(bool(o.is_goal))
        for node in scene.graph.nodes_geometry:
            tf, geom = scene.graph.get(node)
            mesh = scene.geometry[geom]
            owner, _, part = node.partition("/")
            parent = f"/World/Instruments/{_prim_name(owner)}" if owner in objects else "/World/Room"
            m = UsdGeom.Mesh.Define(stage, f"{parent}/{_prim_name(part or owner)}")
            v = np.asarray(mesh.vertices, float) @ tf[:3, :3].T + tf[:3, 3]
            m.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(v.astype(np.float32)))
            m.CreateFaceVertexCountsAttr(Vt.IntArray.FromNumpy(np.full(len(mesh.faces), 3, np.int32)))
            m.CreateFaceVertexIndicesAttr(Vt.IntArray.FromNumpy(np.asarray(mesh.faces, np.int32).ravel()))
            m.CreateSubdivisionSchemeAttr(UsdGeom.Tokens.none)
        for o in spec.goal_objects():
            g = UsdGeom.Xform.Define(stage, f"/World/Goals/{_prim_name(o.id)}_goal")
            g.AddTranslateOp().Set(Gf.Vec3d(float(o.goal[0]), float(o.goal[1]), 0.0))
            prim = g.GetPrim()
            prim.CreateAttribute("biovln:category", Sdf.ValueTypeNames.String).Set(o.category)
            prim.CreateAttribute("biovln:objectId", Sdf.ValueTypeNames.String).Set(o.id)
            prim.CreateAttribute("biovln:successRadius", Sdf.ValueTypeNames.Double).Set(
                float(o.success_radius)
            )
            prim.CreateAttribute("biovln:source", Sdf.ValueTypeNames.String).Set(_goal_source(o))
        stage.GetRootLayer().Save()
        return atomic_write_bytes(out, tmp_path.read_bytes())


def write_json(obj: dict, out: str | Path) -> Path:
    return atomic_write_text(out, json.dumps(obj, indent=1) + "\n")
