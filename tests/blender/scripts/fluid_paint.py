"""Fluid paint through the addon: an Empty paints texture 1 into the fluid at frame 2 and the
paint flows on; a feature rule captured from a selection of the baked surface is stored."""
import os

import bpy
import numpy as np

import in_blender

in_blender.enable()
from hydrobake.core import vdb  # noqa: E402
from hydrobake.core.bake.cache import frame_path  # noqa: E402

tmp = in_blender.args()[0]
bpy.ops.wm.save_as_mainfile(filepath=os.path.join(tmp, "paint.blend"))



domain = in_blender.new_box("Domain", (1.0, 0.5, 0.5), (0.5, 0.25, 0.25))
fill = in_blender.new_box("Column", (0.25, 0.45, 0.4), (0.15, 0.25, 0.21))
brush = bpy.data.objects.new("Brush", None)
brush.empty_display_size, brush.location = 0.12, (0.15, 0.25, 0.2)
strokes = bpy.data.collections.new("Strokes")
bpy.context.scene.collection.children.link(strokes)
strokes.objects.link(brush)
brush.hydrobake_fluid_paint.enabled = True
brush.hydrobake_fluid_paint.texture, brush.hydrobake_fluid_paint.frame = 1, 2
s = domain.hydrobake_fluid
s.enabled, s.fill_object, s.paint_collection = True, fill, strokes
s.fluid.resolution, s.fluid.substeps, s.fluid.textures = (16, 8, 8), 4, 2
s.use_scene_range, s.frame_start, s.frame_end = False, 1, 3
assert bpy.ops.hydrobake.bake(effect="fluid", object_name="Domain") == {"FINISHED"}
b1 = [vdb.read(frame_path(s.bake_folder, "fluid", f, "vdb"))["blend_1"] for f in (1, 3)]
assert b1[0].activeVoxelCount() == 0 or b1[0].evalMinMax()[1] < 1e-6  # nothing before frame 2
assert b1[1].evalMinMax()[1] > 0.5  # painted at frame 2, still there at frame 3

def roughness():
    mat = bpy.data.materials["HBK_Domain_textured"]
    return next(n for n in mat.node_tree.nodes if n.type == "BSDF_PRINCIPLED").inputs[
        "Roughness"]


roughness().default_value = 0.9  # the artist's edit

# Capture a feature rule from a selection of the baked surface.
surf = bpy.data.objects["HBK_Domain_surface"]
sel = np.zeros(len(surf.data.vertices), bool)
sel[: len(sel) // 3] = True
surf.data.vertices.foreach_set("select", sel)
bpy.context.view_layer.objects.active = surf
assert bpy.ops.hydrobake.fluid_capture_rule(texture=1, feature="DENSITY") == {"FINISHED"}
rule = s.rules[0]
vals = np.empty(len(sel), np.float32)
surf.data.attributes["features_0"].data.foreach_get("value", vals)
assert rule.texture == 1 and rule.feature == "DENSITY"
assert abs(rule.low - vals[sel].min()) < 1e-3 and abs(rule.high - vals[sel].max()) < 1e-3
# Re-baked, the rule gives texture 1 from the first frame on, before any paint.
assert bpy.ops.hydrobake.free_bake(effect="fluid", object_name="Domain") == {"FINISHED"}
brush.hydrobake_fluid_paint.enabled = False
assert bpy.ops.hydrobake.bake(effect="fluid", object_name="Domain") == {"FINISHED"}
first = vdb.read(frame_path(s.bake_folder, "fluid", 1, "vdb"))["blend_1"]
assert first.evalMinMax()[1] > 0.5
assert abs(roughness().default_value - 0.9) < 1e-6  # the same textures: the edit is kept
assert bpy.ops.hydrobake.free_bake(effect="fluid", object_name="Domain") == {"FINISHED"}
s.fluid.textures = 3
assert bpy.ops.hydrobake.bake(effect="fluid", object_name="Domain") == {"FINISHED"}
assert abs(roughness().default_value - 0.25) < 1e-6  # three textures: rebuilt

def made(prefix):
    return sorted(o.name for o in bpy.data.objects if o.name.startswith(prefix))


# Renamed after its bake: a re-bake replaces the old objects, and Free Bake finds them.
assert made("HBK_Domain_") == ["HBK_Domain_surface", "HBK_Domain_volume"]
old_folder = s.bake_folder
domain.name = "Tank"
assert bpy.ops.hydrobake.bake(effect="fluid", object_name="Tank") == {"FINISHED"}
assert made("HBK_Domain_") == [] and made("HBK_Tank_") == ["HBK_Tank_surface", "HBK_Tank_volume"]
# The bake under the old name is replaced, as a re-bake in place would be, once the file
# records the new one (saved): until then the file on disk still needs it.
assert s.bake_folder != old_folder and os.path.isdir(s.bake_folder)
assert os.path.isfile(os.path.join(old_folder, "manifest.json"))
bpy.ops.wm.save_mainfile()
assert not os.path.exists(old_folder), os.listdir(old_folder)
domain.name = "Pool"
assert bpy.ops.hydrobake.free_bake(effect="fluid", object_name="Pool") == {"FINISHED"}
assert made("HBK_") == [], made("HBK_")
print("FLUID PAINT OK")
