"""Run inside Blender's Python (the ``bpy`` wheel), headless: install and enable the add-on from its
zip, import the LSAT Target GLB, use the panel's three operators, and print the results as JSON.

    python tests/blender/addon_session.py ADDON_ZIP SCENE_GLB OUT_DIR
"""

import json
import sys

import bpy

addon_zip, scene_glb, out_dir = sys.argv[-3:]
result = {}
bpy.ops.preferences.addon_install(filepath=addon_zip, overwrite=True)
bpy.ops.preferences.addon_enable(module="biovln_lsat")
result["enabled"] = "biovln_lsat" in bpy.context.preferences.addons
result["panel"] = hasattr(bpy.types, "BIOVLN_PT_panel")
bpy.ops.wm.read_factory_settings(use_empty=True)
bpy.ops.preferences.addon_enable(module="biovln_lsat")  # factory settings drop it; enable again
bpy.ops.import_scene.gltf(filepath=scene_glb)
objs = bpy.context.scene.objects
result["imported_markers"] = sorted(o.name for o in objs if o.name.startswith("target_"))

# add a marker for the pipette stand from scratch
bpy.data.objects.remove(objs["target_pipette"], do_unlink=True)
stand = objs["Pipette Stand"]
bpy.context.view_layer.objects.active = stand
result["add_marker"] = sorted(bpy.ops.biovln.add_marker())
marker = bpy.context.scene.objects["target_pipette"]
result["new_marker"] = [marker.location.x, marker.location.y, marker.location.z]

# a misspelt marker is caught, then fixed
objs["target_cabinet"].name = "target_cabbage_xx"
result["check_bad"] = sorted(bpy.ops.biovln.check_markers())
objs["target_cabbage_xx"].name = "target_cabinet"
result["check_good"] = sorted(bpy.ops.biovln.check_markers())

result["import_export"] = sorted(bpy.ops.biovln.import_export(directory=out_dir))
result["coverage"] = str(bpy.context.scene.get("biovln_coverage"))
print("BIOVLN_RESULT " + json.dumps(result))
