"""Renders docs/images/fluid_hose.png: the Inflow's Local Velocity. A nozzle (a ball of 3 cm)
30 cm over the middle of a shallow pool sprays at 0.9 m/s along its own x axis, a little
upwards, while it turns a quarter turn about z over frames 1-16; fluid textured at 40 cells
a side, rendered in Cycles at frame 14, seen from above. Left, Local Velocity off: the
velocity stays along the world's x, and the jet stays straight along it whatever the nozzle
does. Right, on: the velocity turns with the nozzle, so the jet leaves where the nozzle now
points (towards the back) and bends round to where the water that left earlier still flies,
as a sweeping hose's does.

    BLENDER_USER_SCRIPTS=<dir holding addons/hydrobake> blender -b --factory-startup \\
        --python-exit-code 1 --python docs/scripts/fluid_hose.py -- OUTDIR
"""
import math
import os
import sys

import bpy

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from tank_scene import box, compared, floor, start  # noqa: E402

TURN, FRAME = 16, 14
out = start("hose.blend")
scene = bpy.context.scene
tank = box("Tank", (0.8, 0.8, 0.5), (0.4, 0.4, 0.25))
pool = box("Pool", (0.8, 0.8, 0.04), (0.4, 0.4, 0.02))
bpy.ops.mesh.primitive_uv_sphere_add(radius=0.03, location=(0.4, 0.4, 0.3))
nozzle = bpy.context.active_object
pool.hide_render = nozzle.hide_render = True
for frame, turn in ((1, 0.0), (TURN, math.pi / 2)):
    nozzle.rotation_euler.z = turn
    nozzle.keyframe_insert("rotation_euler", index=2, frame=frame)
for fc in nozzle.animation_data.action.fcurves:
    for k in fc.keyframe_points:
        k.interpolation = "LINEAR"
s = tank.hydrobake_fluid
s.inflow_object, s.inflow_velocity = nozzle, (0.9, 0.0, 0.3)
s.inflow_start, s.inflow_end = 1, TURN
s.fluid.max_particles = 200000
solids = bpy.data.collections.new("Solids")
scene.collection.children.link(solids)
floor(0.4, 0.4)
compared(tank, pool, solids, FRAME, (40, 40, 25),
         [(label, lambda on=on: setattr(s, "inflow_local", on))
          for label, on in (("world", False), ("local", True))],
         (0.4, 0.0, 1.25), 20, out, "fluid_hose")
