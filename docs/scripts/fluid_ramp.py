"""Renders docs/images/fluid_ramp.png's halves: a block of water dropped onto a board tilted
20 degrees (a still obstacle), the fluid textured and baked at 64 cells along the tank,
rendered at frame 18 in Cycles. The right half as the addon bakes it since the turned boxes
(the board is its own box, turned with it); with ``box``, the left half: the board taken as
its world bounding box, as every obstacle was before.

    BLENDER_USER_SCRIPTS=<dir holding addons/hydrobake> blender -b --factory-startup \\
        --python-exit-code 1 --python docs/scripts/fluid_ramp.py -- OUTDIR [box]
"""
import math
import os
import sys

import bpy

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from tank_scene import bake, box, floor, material, render, start  # noqa: E402

as_box = sys.argv[-1] == "box"
out = start("box.blend" if as_box else "ramp.blend")
if as_box:
    from hydrobake.blender.bridge import meshes
    meshes.turned_bounds = lambda obj: None
scene = bpy.context.scene
tank = box("Tank", (1.6, 0.6, 0.6), (0.8, 0.3, 0.3))
water = box("Water", (0.34, 0.6, 0.16), (0.19, 0.3, 0.5))
water.hide_render = True
ramp = box("Ramp", (1.0, 0.6, 0.04), (0.55, 0.3, 0.22))
ramp.rotation_euler.y = math.radians(20.0)  # its +x end down
ramp.data.materials.append(material("Wood", (0.35, 0.18, 0.07, 1.0)))
boards = bpy.data.collections.new("Boards")
scene.collection.children.link(boards)
boards.objects.link(ramp)  # (also in the scene's collection: rendered)
floor(0.8, 0.3)
bake(tank, water, boards, 18, (64, 24, 24))
render(18, (0.8, -1.5, 1.5), 52, (480, 300),
       os.path.join(out, "fluid_ramp_box.png" if as_box else "fluid_ramp.png"))
