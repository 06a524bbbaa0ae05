"""Renders docs/images/fluid_inflow.png: the Inflow object (1f01a04). A small tap (a ball of
4 cm) high over one end of a tank pours down and sideways into a shallow pool from frame 1
to frame 14; the fluid textured and baked at 40 cells along the tank, rendered in Cycles at
frame 8 (left: the stream falling, its splash spreading) and frame 16 (right: the tap shut
at 14, the last of the stream landing in the risen pool).

    BLENDER_USER_SCRIPTS=<dir holding addons/hydrobake> blender -b --factory-startup \\
        --python-exit-code 1 --python docs/scripts/fluid_inflow.py -- OUTDIR
"""
import os
import sys

import bpy

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from tank_scene import bake, box, floor, start, two_frames  # noqa: E402

out = start("inflow.blend")
scene = bpy.context.scene
tank = box("Tank", (0.8, 0.5, 0.6), (0.4, 0.25, 0.3))
pool = box("Pool", (0.8, 0.5, 0.05), (0.4, 0.25, 0.025))
bpy.ops.mesh.primitive_uv_sphere_add(radius=0.04, location=(0.12, 0.25, 0.5))
tap = bpy.context.active_object
pool.hide_render = tap.hide_render = True
s = tank.hydrobake_fluid
s.inflow_object, s.inflow_velocity = tap, (0.8, 0.0, -0.6)
s.inflow_start, s.inflow_end = 1, 14
s.fluid.max_particles = 200000
solids = bpy.data.collections.new("Solids")
scene.collection.children.link(solids)
floor(0.4, 0.25)
bake(tank, pool, solids, 16, (40, 25, 30))
two_frames((8, 16), (0.4, -0.95, 0.72), 66, out, "fluid_inflow")
