"""Renders docs/images/fluid_sprinkler.png: the Inflow's Normal velocity. A ball of 4 cm held
30 cm over a shallow pool sprays 1.2 m/s along its surface normal and nothing else (Inflow
Velocity 0) from frame 1 to frame 14: its water leaves all round, from points laid on its
surface, and falls in an umbrella. The fluid textured and baked at 40 cells along the tank,
rendered in Cycles at frame 3 (left: the umbrella opening) and frame 12 (right: it has reached
the pool all round).

    BLENDER_USER_SCRIPTS=<dir holding addons/hydrobake> blender -b --factory-startup \\
        --python-exit-code 1 --python docs/scripts/fluid_sprinkler.py -- OUTDIR
"""
import os
import sys

import bpy

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from tank_scene import bake, box, floor, start, two_frames  # noqa: E402

out = start("sprinkler.blend")
scene = bpy.context.scene
tank = box("Tank", (0.8, 0.5, 0.6), (0.4, 0.25, 0.3))
pool = box("Pool", (0.8, 0.5, 0.05), (0.4, 0.25, 0.025))
bpy.ops.mesh.primitive_uv_sphere_add(radius=0.04, location=(0.4, 0.25, 0.32))
head = bpy.context.active_object
pool.hide_render = head.hide_render = True
s = tank.hydrobake_fluid
s.inflow_object, s.inflow_velocity, s.inflow_normal = head, (0.0, 0.0, 0.0), 1.2
s.inflow_start, s.inflow_end = 1, 14
s.fluid.max_particles = 200000
solids = bpy.data.collections.new("Solids")
scene.collection.children.link(solids)
floor(0.4, 0.25)
bake(tank, pool, solids, 14, (40, 25, 30))
two_frames((3, 12), (0.4, -0.95, 0.72), 66, out, "fluid_sprinkler")
