"""BioVLN LSAT: the LabScene Annotation Toolkit as a Blender add-on (paper §3.4, Table 1).

A sidebar panel in the 3D Viewport (N panel, tab "BioVLN") to annotate a designer-built lab:

- **Add target marker**: an empty ``target_<category>`` on the floor in front of the selected
  instrument's operational face (Eq. 1, the catalog's face turned by the object's yaw);
- **Check markers**: every ``target_*`` name against the catalog (fuzzy, Levenshtein <= 2);
- **Import / export**: export the scene as GLB (+Y up), run the LSAT import on it and write the scene
  spec, the coverage report, the BioVLN goal JSON, the LSAT intermediate format and (when ``usd-core``
  is installed) a USD stage.

All of it calls the ``biovln_ms`` library (names, markers, importer, exporters): install biovln-ms into
Blender's Python, or set the add-on preference "biovln-ms location" to a folder that holds it.
Install: Edit > Preferences > Add-ons > Install from Disk > ``biovln_lsat.zip`` (``biovln-ms lsat
blender-addon -o biovln_lsat.zip`` writes it).
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import bpy
from bpy.props import StringProperty

bl_info = {
    "name": "BioVLN LSAT",
    "author": "BioVLN-MS",
    "version": (0, 1, 0),
    "blender": (4, 2, 0),
    "location": "3D Viewport > Sidebar > BioVLN",
    "description": "Annotate lab scenes for BioVLN: target markers, checks, import and export",
    "category": "Import-Export",
}


def _library():
    """Import biovln_ms, adding the preference's folder to sys.path first when set."""
    prefs = bpy.context.preferences.addons.get(__name__)
    extra = prefs.preferences.library_path if prefs else ""
    if extra and extra not in sys.path:
        sys.path.insert(0, extra)
    import biovln_ms.lsat.markers as markers

    return markers


class BIOVLN_AddonPreferences(bpy.types.AddonPreferences):
    bl_idname = __name__
    library_path: StringProperty(
        name="biovln-ms location",
        subtype="DIR_PATH",
        description="A folder holding the biovln_ms package, if Blender's Python does not",
    )

    def draw(self, context):
        self.layout.prop(self, "library_path")


class BIOVLN_OT_add_marker(bpy.types.Operator):
    """Add a target_<category> marker in front of the selected instrument's operational face"""

    bl_idname = "biovln.add_marker"
    bl_label = "Add target marker"
    bl_options = {"REGISTER", "UNDO"}

    def execute(self, context):
        obj = context.active_object
        if obj is None:
            self.report({"ERROR"}, "select an instrument first")
            return {"CANCELLED"}
        from biovln_ms.errors import BioVLNError

        markers = _library()
        loc = obj.matrix_world.translation
        yaw = obj.matrix_world.to_euler("XYZ").z
        try:
            name, (x, y) = markers.suggested_marker(obj.name, (loc.x, loc.y), yaw)
        except BioVLNError as e:
            self.report({"ERROR"}, str(e))
            return {"CANCELLED"}
        empty = bpy.data.objects.new(name, None)
        empty.empty_display_type = "SINGLE_ARROW"
        empty.location = (x, y, 0.0)
        empty.rotation_euler = (0.0, 0.0, yaw + math.pi)
        context.collection.objects.link(empty)
        self.report({"INFO"}, f"{empty.name} at ({x:.2f}, {y:.2f})")
        return {"FINISHED"}


class BIOVLN_OT_check_markers(bpy.types.Operator):
    """Check every target_* marker name against the BioVLN catalog"""

    bl_idname = "biovln.check_markers"
    bl_label = "Check markers"

    def execute(self, context):
        rows = _library().check_markers([o.name for o in context.scene.objects])
        bad = [r for r in rows if r["status"] != "ok"]
        for r in bad:
            extra = f" ({', '.join(r['candidates'])})" if r["candidates"] else ""
            self.report({"WARNING"}, f"{r['name']}: {r['status']}{extra}")
        context.scene["biovln_marker_check"] = f"{len(rows) - len(bad)} ok, {len(bad)} to fix"
        self.report({"INFO"}, f"{len(rows)} markers: {len(rows) - len(bad)} ok, {len(bad)} to fix")
        return {"FINISHED"} if not bad else {"CANCELLED"}


class BIOVLN_OT_import_export(bpy.types.Operator):
    """Export the scene as GLB, run the LSAT import on it and write spec, report, goals, LSAT format, USD"""

    bl_idname = "biovln.import_export"
    bl_label = "Import / export"

    directory: StringProperty(name="Output folder", subtype="DIR_PATH", default="//biovln")

    def execute(self, context):
        from biovln_ms.errors import BioVLNError

        _library()
        from biovln_ms.io_utils import atomic_write_text
        from biovln_ms.lsat.exporters import goal_json, lsat_json, write_json, write_usd
        from biovln_ms.lsat.importer import import_glb, name_as_id

        out = Path(bpy.path.abspath(self.directory))
        out.mkdir(parents=True, exist_ok=True)
        name = name_as_id(Path(bpy.data.filepath).stem) if bpy.data.filepath else "scene"  # an id
        glb = out / f"{name}.glb"
        bpy.ops.export_scene.gltf(
            filepath=str(glb), export_format="GLB", export_yup=True, use_selection=False
        )
        try:  # the report is written even when the import fails: it lists every problem
            spec, report = import_glb(glb, name=name, report_path=out / f"{name}.report.md")
        except BioVLNError as e:
            self.report({"ERROR"}, str(e))
            return {"CANCELLED"}
        atomic_write_text(out / f"{name}.json", spec.to_json())
        write_json(goal_json(spec), out / f"{name}.goals.json")
        write_json(lsat_json(spec, report), out / f"{name}.lsat.json")
        try:
            write_usd(spec, out / f"{name}.usda")
        except BioVLNError as e:  # usd-core not installed in Blender's Python
            self.report({"WARNING"}, str(e))
        c = report.coverage()
        context.scene["biovln_coverage"] = (
            f"{c['instruments_found']} instruments, {c['goals_strategy1']} marker goals, "
            f"{c['goals_strategy2']} Eq. 1 goals, {len(c['missing'])} missing"
        )
        self.report({"INFO"}, f"wrote {out}: {context.scene['biovln_coverage']}")
        return {"FINISHED"}


class BIOVLN_PT_panel(bpy.types.Panel):
    bl_label = "BioVLN LSAT"
    bl_idname = "BIOVLN_PT_panel"
    bl_space_type = "VIEW_3D"
    bl_region_type = "UI"
    bl_category = "BioVLN"

    def draw(self, context):
        col = self.layout.column(align=True)
        col.operator(BIOVLN_OT_add_marker.bl_idname, icon="EMPTY_SINGLE_ARROW")
        col.operator(BIOVLN_OT_check_markers.bl_idname, icon="CHECKMARK")
        col.operator(BIOVLN_OT_import_export.bl_idname, icon="EXPORT")
        for key in ("biovln_marker_check", "biovln_coverage"):
            if key in context.scene:
                self.layout.label(text=str(context.scene[key]))


CLASSES = (
    BIOVLN_AddonPreferences,
    BIOVLN_OT_add_marker,
    BIOVLN_OT_check_markers,
    BIOVLN_OT_import_export,
    BIOVLN_PT_panel,
)


def register():
    for cls in CLASSES:
        bpy.utils.register_class(cls)


def unregister():
    for cls in reversed(CLASSES):
        bpy.utils.unregister_class(cls)
