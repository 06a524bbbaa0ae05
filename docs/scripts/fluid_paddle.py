"""Renders docs/images/fluid_paddle.png's halves: a paddle keyed to sweep through shallow water
(frames 1-24), the fluid textured and baked at 64 cells along the tank, rendered at frame 20 in
Cycles. Run with the addon of a8423d4 for the left half (the paddle read once, where it stands
at frame 1), with d388f7a or later for the right (followed frame by frame). With ``ball``:
docs/images/fluid_ball.png, a ball keyed to drop into the water (frames 1-12; a sphere
obstacle since the commit after 7090d39), rendered at frame 14.

    BLENDER_USER_SCRIPTS=<dir holding addons/hydrobake> blender -b --factory-startup \\
        --python-exit-code 1 --python docs/scripts/fluid_paddle.py -- OUTDIR [ball]
"""
import math
import os
import sys

import addon_utils
import bpy

out = os.path.abspath(sys.argv[sys.argv.index("--") + 1])
ball = sys.argv[-1] == "ball"
bpy.ops.wm.read_factory_settings(use_empty=True)
addon_utils.enable("hydrobake", default_set=True)
bpy.ops.wm.save_as_mainfile(filepath=os.path.join(out, "ball.blend" if ball else "paddle.blend"))
scene = bpy.context.scene


def box(name, size, location):
    bpy.ops.mesh.primitive_cube_add(size=1.0, location=location)
    obj = bpy.context.active_object
    obj.name, obj.scale = name, size
    return obj


def material(name, colour, roughness=0.6):
    mat = bpy.data.materials.new(name)
    mat.use_nodes = True
    bsdf = mat.node_tree.nodes["Principled BSDF"]
    bsdf.inputs["Base Color"].default_value = colour
    bsdf.inputs["Roughness"].default_value = roughness
    return mat


tank = box("Tank", (1.6, 0.6, 0.5), (0.8, 0.3, 0.25))
water = box("Water", (1.6, 0.6, 0.12), (0.8, 0.3, 0.06))
water.hide_render = True
if ball:
    bpy.ops.mesh.primitive_uv_sphere_add(radius=0.15, location=(0.8, 0.3, 0.9))
    paddle = bpy.context.active_object
    keys, axis = ((1, 0.9), (12, 0.08)), 2  # falling, then resting on the floor
else:
    paddle = box("Paddle", (0.06, 0.4, 0.45), (1.4, 0.3, 0.2))
    keys, axis = ((1, 1.4), (24, 0.4)), 0
paddle.data.materials.append(material("Wood", (0.35, 0.18, 0.07, 1.0)))
for frame, x in keys:
    paddle.location[axis] = x
    paddle.keyframe_insert("location", index=axis, frame=frame)
for k in paddle.animation_data.action.fcurves[0].keyframe_points:
    k.interpolation = "LINEAR"
paddles = bpy.data.collections.new("Paddles")
scene.collection.children.link(paddles)
paddles.objects.link(paddle)  # (also in the scene's collection: rendered)
bpy.ops.mesh.primitive_plane_add(size=6, location=(0.8, 0.3, 0.0))
bpy.context.active_object.data.materials.append(material("Floor", (0.2, 0.22, 0.25, 1.0)))

s = tank.hydrobake_fluid
s.enabled, s.fill_object, s.obstacles = True, water, paddles
s.use_scene_range, s.frame_start, s.frame_end = False, 1, 20
s.fluid.resolution = (64, 24, 20)
scene.frame_set(1)
assert bpy.ops.hydrobake.bake(effect="fluid", object_name="Tank") == {"FINISHED"}

scene.frame_set(14 if ball else 20)
cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
scene.collection.objects.link(cam)
cam.location, cam.rotation_euler = (0.8, -1.3, 1.7), (math.radians(45), 0.0, 0.0)
scene.camera = cam
sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
scene.collection.objects.link(sun)
sun.rotation_euler = (math.radians(35), math.radians(-15), math.radians(20))
sun.data.energy = 3.0
scene.world = bpy.data.worlds.new("Sky")
scene.world.use_nodes = True
scene.world.node_tree.nodes["Background"].inputs["Color"].default_value = (0.4, 0.45, 0.55, 1)
scene.render.engine = "CYCLES"
scene.cycles.samples, scene.cycles.use_denoising = 32, False
scene.render.resolution_x, scene.render.resolution_y = 480, 300
scene.render.filepath = os.path.join(out, "fluid_ball.png" if ball else "fluid_paddle.png")
bpy.ops.render.render(write_still=True)
print("RENDERED", scene.render.filepath)
