"""Renders docs/images/fluid_paddle.png's halves: a paddle keyed to sweep through shallow water
(frames 1-24), the fluid textured and baked at 64 cells along the tank, rendered at frame 20 in
Cycles. Run with the addon of a8423d4 for the left half (the paddle read once, where it stands
at frame 1), with d388f7a or later for the right (followed frame by frame). With ``ball``:
docs/images/fluid_ball.png, a ball keyed to drop into the water (frames 1-12; a sphere
obstacle since the commit after 7090d39), rendered at frame 14.

    BLENDER_USER_SCRIPTS=<dir holding addons/hydrobake> blender -b --factory-startup \\
        --python-exit-code 1 --python docs/scripts/fluid_paddle.py -- OUTDIR [ball]
"""
import os
import sys

import bpy

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from tank_scene import bake, box, floor, material, render, start  # noqa: E402

ball = sys.argv[-1] == "ball"
out = start("ball.blend" if ball else "paddle.blend")
scene = bpy.context.scene
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
floor(0.8, 0.3)
bake(tank, water, paddles, 20, (64, 24, 20))
render(14 if ball else 20, (0.8, -1.3, 1.7), 45, (480, 300),
       os.path.join(out, "fluid_ball.png" if ball else "fluid_paddle.png"))
