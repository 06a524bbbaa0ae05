"""Renders docs/images/snow_deforming.png's right half: a post that bends over in a blizzard
(Simple Deform, 0 to 100 degrees over frames 1-50), snow baked over frames 1-150 and rendered
at 150 in Cycles. The left half is the same script with the addon of 63dbdf7, which moved
the first frame's straight post instead of bending it.

    BLENDER_USER_SCRIPTS=<dir holding addons/hydrobake> blender -b --factory-startup \\
        --python-exit-code 1 --python docs/scripts/snow_bend.py -- OUTDIR
"""
import math
import os
import sys

import addon_utils
import bpy

out = os.path.abspath(sys.argv[sys.argv.index("--") + 1])
bpy.ops.wm.read_factory_settings(use_empty=True)
addon_utils.enable("hydrobake", default_set=True)
bpy.ops.wm.save_as_mainfile(filepath=os.path.join(out, "bend.blend"))
scene = bpy.context.scene


def material(name, colour):
    mat = bpy.data.materials.new(name)
    mat.use_nodes = True
    bsdf = mat.node_tree.nodes["Principled BSDF"]
    bsdf.inputs["Base Color"].default_value = colour
    bsdf.inputs["Roughness"].default_value = 0.9  # catches 45 % of the flakes that touch it
    return mat


bpy.ops.mesh.primitive_cylinder_add(vertices=32, radius=0.25, depth=3.0, location=(0, 0, 1.5))
post = bpy.context.active_object
post.name = "Post"
bpy.ops.object.mode_set(mode="EDIT")
bpy.ops.mesh.subdivide(number_cuts=24)  # (rings for the bend)
bpy.ops.object.mode_set(mode="OBJECT")
post.data.materials.append(material("Wood", (0.25, 0.12, 0.05, 1.0)))
bend = post.modifiers.new("Bend", "SIMPLE_DEFORM")
bend.deform_method, bend.deform_axis = "BEND", "Y"
bend.origin = bpy.data.objects.new("Foot", None)
scene.collection.objects.link(bend.origin)
bend.angle = 0.0
bend.keyframe_insert("angle", frame=1)
bend.angle = math.radians(100.0)
bend.keyframe_insert("angle", frame=50)
bpy.ops.mesh.primitive_plane_add(size=8)
bpy.context.active_object.data.materials.append(material("Ground", (0.05, 0.05, 0.06, 1.0)))

s = post.hydrobake_snow
s.enabled, s.use_scene_range, s.frame_start, s.frame_end = True, False, 1, 150
s.flake_density = 15000.0  # a blizzard
s.snow.texture_width = s.snow.texture_height = 256
s.snow.wind = (0.0, 0.0, 0.0)
scene.frame_set(1)  # the post straight, as its animation has it there
assert bpy.ops.hydrobake.bake(effect="snow", object_name="Post") == {"FINISHED"}

scene.frame_set(150)
cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
scene.collection.objects.link(cam)
cam.location, cam.rotation_euler = (1.0, -7.0, 4.0), (math.radians(68), 0.0, 0.0)
scene.camera = cam
sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
scene.collection.objects.link(sun)
sun.rotation_euler = (math.radians(40), math.radians(-20), math.radians(30))
sun.data.energy = 3.0
scene.world = bpy.data.worlds.new("Sky")
scene.world.use_nodes = True
scene.world.node_tree.nodes["Background"].inputs["Color"].default_value = (0.35, 0.4, 0.5, 1)
scene.render.engine = "CYCLES"
scene.cycles.samples, scene.cycles.use_denoising = 24, False
scene.render.resolution_x, scene.render.resolution_y = 480, 400
scene.render.filepath = os.path.join(out, "snow_bend.png")
bpy.ops.render.render(write_still=True)
print("RENDERED", scene.render.filepath)
