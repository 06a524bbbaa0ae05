"""Prepares a baked copy of the caustics example for a shared-folder render farm: placeholders
on, overwrite off, a tiny fast render, the bake wired in, saved."""
import bpy

import in_blender

in_blender.enable()
out = in_blender.args()[0]
for scene in list(bpy.data.scenes):
    if scene.name != "Caustics":
        bpy.data.scenes.remove(scene)
scene = bpy.data.scenes["Caustics"]
water = bpy.data.objects["Water"]
s = water.hydrobake_caustics
s.use_scene_range, s.frame_start, s.frame_end = False, 1, 6
s.water.width, s.map_resolution = 32, 64
assert bpy.ops.hydrobake.bake(effect="caustics", object_name="Water") == {"FINISHED"}
r = scene.render
r.use_overwrite, r.use_placeholder = False, True
r.resolution_x, r.resolution_y, r.resolution_percentage = 48, 27, 100
r.filepath = out
r.image_settings.file_format = "PNG"
scene.cycles.samples = 1
scene.frame_start, scene.frame_end = 1, 6
bpy.ops.wm.save_mainfile()
print("FARM READY")
