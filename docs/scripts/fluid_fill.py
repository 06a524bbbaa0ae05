"""Renders docs/images/fluid_fill.png: the Fill object taken by its shape (23d256e). A torus
lying flat high in a tank is the Fill; the fluid textured and baked at 40 cells along the
tank, rendered in Cycles at frame 1 (left: the water is the ring, its hole dry, before it
falls; as the addon baked it before, it would have been the ring's whole bounding box) and
at frame 6 (right: the ring lands and its water runs out and into the middle).

    BLENDER_USER_SCRIPTS=<dir holding addons/hydrobake> blender -b --factory-startup \\
        --python-exit-code 1 --python docs/scripts/fluid_fill.py -- OUTDIR
"""
import os
import sys

import bpy

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from tank_scene import bake, box, floor, start, two_frames  # noqa: E402

out = start("fill.blend")
scene = bpy.context.scene
tank = box("Tank", (0.8, 0.5, 0.6), (0.4, 0.25, 0.3))
bpy.ops.mesh.primitive_torus_add(major_radius=0.15, minor_radius=0.06, location=(0.4, 0.25, 0.3))
ring = bpy.context.active_object
ring.hide_render = True
solids = bpy.data.collections.new("Solids")
scene.collection.children.link(solids)
floor(0.4, 0.25)
bake(tank, ring, solids, 6, (40, 25, 30))
two_frames((1, 6), (0.4, -0.75, 0.75), 60, out, "fluid_fill")
