"""Renders docs/images/fluid_planar.png: a planar Inflow. A Plane 24 x 6 cm, stood on its edge
at the tank's left wall and facing +x, pours with Normal 1 m/s (its Inflow Velocity 0) from
frame 1 to frame 16: its water leaves its face as a curtain, one side only, and arcs down into
a shallow pool. The fluid textured and baked at 40 cells along the tank, rendered in Cycles at
frame 5 (left: the curtain leaving the plane) and frame 16 (right: it has reached the pool).

    BLENDER_USER_SCRIPTS=<dir holding addons/hydrobake> blender -b --factory-startup \\
        --python-exit-code 1 --python docs/scripts/fluid_planar.py -- OUTDIR
"""
import math
import os
import sys

import bpy

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from tank_scene import bake, box, floor, start, two_frames  # noqa: E402

out = start("planar.blend")
scene = bpy.context.scene
tank = box("Tank", (0.8, 0.5, 0.6), (0.4, 0.25, 0.3))
pool = box("Pool", (0.8, 0.5, 0.05), (0.4, 0.25, 0.025))
bpy.ops.mesh.primitive_plane_add(size=1.0, location=(0.06, 0.25, 0.42),
                                 rotation=(0.0, math.pi / 2, 0.0))
sheet = bpy.context.active_object
sheet.scale = (0.06, 0.24, 1.0)  # (its own x is the world's z once stood up)
pool.hide_render = sheet.hide_render = True
s = tank.hydrobake_fluid
s.inflow_object, s.inflow_velocity, s.inflow_normal = sheet, (0.0, 0.0, 0.0), 1.0
s.inflow_start, s.inflow_end = 1, 16
s.fluid.max_particles = 200000
solids = bpy.data.collections.new("Solids")
scene.collection.children.link(solids)
floor(0.4, 0.25)
bake(tank, pool, solids, 16, (40, 25, 30))
two_frames((5, 16), (1.0, -0.6, 0.72), 64, out, "fluid_planar", turn=35.0)
