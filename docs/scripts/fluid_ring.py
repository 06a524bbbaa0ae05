"""Renders docs/images/fluid_ring.png's halves: a block of water dropped over a ring (a torus
mesh, tilted a little) standing over the floor of a tank, the fluid textured and baked at 48
cells a side, rendered at frame 10 in Cycles. The right half as the addon bakes it since the
mesh obstacles (the ring is its shape: water falls through its hole and flows round its tube);
with ``box``, the left half: the ring taken as its own box, as before.

    BLENDER_USER_SCRIPTS=<dir holding addons/hydrobake> blender -b --factory-startup \\
        --python-exit-code 1 --python docs/scripts/fluid_ring.py -- OUTDIR [box]
"""
import math
import os
import sys
import time

import bpy

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from tank_scene import bake, box, floor, material, render, start  # noqa: E402

as_box = sys.argv[-1] == "box"
out = start("box.blend" if as_box else "ring.blend")
from hydrobake.blender.bridge import mesh_fields  # noqa: E402
if as_box:
    mesh_fields.mesh_shape = lambda *a: None
else:  # how long the field takes
    shape = mesh_fields.mesh_shape

    def timed(*a):
        t = time.perf_counter()
        s = shape(*a)
        print(f"FIELD {s.field.shape} in {time.perf_counter() - t:.2f} s")
        return s
    mesh_fields.mesh_shape = timed
scene = bpy.context.scene
tank = box("Tank", (1.0, 1.0, 0.8), (0.5, 0.5, 0.4))
water = box("Water", (0.2, 0.2, 0.24), (0.5, 0.5, 0.66))
water.hide_render = True
bpy.ops.mesh.primitive_torus_add(major_radius=0.22, minor_radius=0.06, location=(0.5, 0.5, 0.3),
                                 rotation=(math.radians(12), 0.0, 0.0))
ring = bpy.context.active_object
bpy.ops.object.shade_smooth()
ring.data.materials.append(material("Brass", (0.6, 0.45, 0.15, 1.0), 0.3))
rings = bpy.data.collections.new("Rings")
scene.collection.children.link(rings)
rings.objects.link(ring)  # (also in the scene's collection: rendered)
floor(0.5, 0.5)
bake(tank, water, rings, 10, (48, 48, 40))
render(10, (0.5, -1.25, 0.95), 66, (480, 330),
       os.path.join(out, "fluid_ring_box.png" if as_box else "fluid_ring.png"))
