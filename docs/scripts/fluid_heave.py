"""Renders docs/images/fluid_heave.png's halves: a disc on the floor of a shallow tank (a
cylinder mesh) heaves up 10 cm in three frames by a keyed shape key, the fluid textured and
baked at 40 cells along the tank, rendered at frame 7 in Cycles. The right half as the addon
bakes it since 3843385 (each frame's SPH steps change the disc's field into the next frame's,
and the water meets its top moving up: it rides up on it as a dome); with ``at_once``, the left half:
each frame's field swapped in at once, as before (the water in the disc's new shape is put
outside it with no speed of its own and, packed against it, bursts).

    BLENDER_USER_SCRIPTS=<dir holding addons/hydrobake> blender -b --factory-startup \\
        --python-exit-code 1 --python docs/scripts/fluid_heave.py -- OUTDIR [at_once]
"""
import os
import sys

import bpy

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from tank_scene import bake, box, floor, material, render, start  # noqa: E402

at_once = sys.argv[-1] == "at_once"
out = start("at_once.blend" if at_once else "heave.blend")
if at_once:
    from hydrobake.core import fluid as core_fluid  # noqa: E402
    whole = core_fluid.Fluid._set_fields
    core_fluid.Fluid._set_fields = lambda self, checked, how=None: whole(self, checked)
scene = bpy.context.scene
tank = box("Tank", (0.8, 0.5, 0.6), (0.4, 0.25, 0.3))
water = box("Water", (0.8, 0.5, 0.1), (0.4, 0.25, 0.05))
water.hide_render = True
bpy.ops.mesh.primitive_cylinder_add(vertices=32, radius=0.11, depth=0.04,
                                    location=(0.4, 0.25, 0.02))
disc = bpy.context.active_object
disc.data.materials.append(material("Rubber", (0.55, 0.12, 0.08, 1.0), 0.5))
disc.shape_key_add(name="Basis")
up = disc.shape_key_add(name="Up")
for v in up.data:
    if v.co.z > 0.0:
        v.co.z += 0.10
for frame, value in ((3, 0.0), (6, 1.0)):
    up.value = value
    up.keyframe_insert("value", frame=frame)
for fc in disc.data.shape_keys.animation_data.action.fcurves:
    for kp in fc.keyframe_points:
        kp.interpolation = "LINEAR"
solids = bpy.data.collections.new("Solids")
scene.collection.children.link(solids)
solids.objects.link(disc)  # (also in the scene's collection: rendered)
floor(0.4, 0.25)
bake(tank, water, solids, 7, (40, 25, 30))
render(7, (0.4, -0.7, 0.95), 50, (480, 330),
       os.path.join(out, "fluid_heave_at_once.png" if at_once else "fluid_heave.png"))
