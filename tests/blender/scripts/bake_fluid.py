"""Fluid texturing through the addon: SPH fills a box inside a domain; the bake becomes a
Volume object with the VDB grids and a textured surface mesh that follows the frame."""
import os

import bpy

import in_blender

in_blender.enable()
from hydrobake.blender.bridge import volumes  # noqa: E402

tmp = in_blender.args()[0]
bpy.ops.wm.save_as_mainfile(filepath=os.path.join(tmp, "dam.blend"))
scene = bpy.context.scene
import bmesh  # noqa: E402
domain = in_blender.new_plane("Domain")  # made a unit cube below
bm = bmesh.new()
bmesh.ops.create_cube(bm, size=1.0)
bm.to_mesh(domain.data)
bm.free()
domain.scale, domain.location = (1.0, 0.5, 0.5), (0.5, 0.25, 0.25)
fill = in_blender.new_plane("Water Column")
bm = bmesh.new()
bmesh.ops.create_cube(bm, size=1.0)
bm.to_mesh(fill.data)
bm.free()
fill.scale, fill.location = (0.25, 0.45, 0.4), (0.15, 0.25, 0.21)
s = domain.hydrobake_fluid
s.enabled, s.fill_object = True, fill
s.fluid.resolution = (16, 8, 8)
s.fluid.substeps = 8
s.fluid.textures = 2
s.use_scene_range, s.frame_start, s.frame_end = False, 1, 3
assert bpy.ops.hydrobake.bake(effect="fluid", object_name="Domain") == {"FINISHED"}
vol = bpy.data.objects["HBK_Domain_volume"]
scene.frame_set(2)
grids = volumes.grid_names(vol)
assert {"density", "velocity", "uvw", "uvw_b", "blend_0", "blend_1"} <= set(grids), grids
surf = bpy.data.objects["HBK_Domain_surface"]
assert len(surf.data.polygons) > 0 and "uvw_a" in surf.data.attributes
assert "uvw_weight" in surf.data.attributes and "blend_1" in surf.data.attributes
n2 = len(surf.data.vertices)
scene.frame_set(3)
assert len(surf.data.vertices) > 0
assert surf.data.materials[0].name == "HBK_Domain_textured"
assert bpy.ops.hydrobake.free_bake(effect="fluid", object_name="Domain") == {"FINISHED"}
assert "HBK_Domain_volume" not in bpy.data.objects and "HBK_Domain_surface" not in bpy.data.objects
print("FLUID BLENDER OK", n2)
