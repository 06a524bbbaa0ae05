"""Renders docs/images/fluid_taps.png: several inflows. Three nozzles (4 cm cubes) in the
Inflows collection, along the tank's back over a shallow pool, each tilted its own way, pour
with Local Velocity 1.3 m/s along their own z from frame 1 to frame 16: three jets fan out
and arc into the pool. The fluid textured and baked at 40 cells along the tank, rendered in
Cycles at frame 6 (left) and frame 16 (right).

    BLENDER_USER_SCRIPTS=<dir holding addons/hydrobake> blender -b --factory-startup \\
        --python-exit-code 1 --python docs/scripts/fluid_taps.py -- OUTDIR
"""
import os
import sys

import bpy

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from tank_scene import bake, box, floor, start, two_frames  # noqa: E402

out = start("taps.blend")
scene = bpy.context.scene
tank = box("Tank", (0.8, 0.5, 0.6), (0.4, 0.25, 0.3))
pool = box("Pool", (0.8, 0.5, 0.05), (0.4, 0.25, 0.025))
nozzles = bpy.data.collections.new("Nozzles")
scene.collection.children.link(nozzles)
for k, (x, tilt) in enumerate(((0.2, -0.5), (0.4, 0.0), (0.6, 0.5))):
    n = box(f"Nozzle{k}", (0.04, 0.04, 0.04), (x, 0.4, 0.3))
    n.rotation_euler = (0.6, tilt, 0.0)  # (leaning toward the camera, fanned sideways)
    nozzles.objects.link(n)
    n.hide_render = True
pool.hide_render = True
s = tank.hydrobake_fluid
s.inflow_collection, s.inflow_velocity, s.inflow_local = nozzles, (0.0, 0.0, 1.3), True
s.inflow_start, s.inflow_end = 1, 16
s.fluid.max_particles = 200000
solids = bpy.data.collections.new("Solids")
scene.collection.children.link(solids)
floor(0.4, 0.25)
bake(tank, pool, solids, 16, (40, 25, 30))
two_frames((6, 16), (0.4, -0.95, 0.72), 66, out, "fluid_taps")
