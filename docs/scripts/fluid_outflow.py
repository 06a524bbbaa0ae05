"""Renders docs/images/fluid_outflow.png: the Outflow object. A tap (a ball of 6 cm) at one
end of a dry tank pours down and along it from frame 1; the far quarter of the floor is a
drain (a dark grate; the Outflow is a hidden box through it). Baked twice at 40 cells along
the tank and rendered in Cycles at frame 60: left without the Outflow (the water spreads
over the whole floor and rises), right with it (the water runs into the grate and is gone,
so a tap can pour for as long as the shot lasts).

    BLENDER_USER_SCRIPTS=<dir holding addons/hydrobake> blender -b --factory-startup \\
        --python-exit-code 1 --python docs/scripts/fluid_outflow.py -- OUTDIR
"""
import os
import sys

import bpy

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from tank_scene import box, compared, floor, material, start  # noqa: E402

FRAME = 60
out = start("outflow.blend")
scene = bpy.context.scene
tank = box("Tank", (0.8, 0.5, 0.6), (0.4, 0.25, 0.3))
bpy.ops.mesh.primitive_uv_sphere_add(radius=0.06, location=(0.12, 0.25, 0.45))
tap = bpy.context.active_object
drain = box("Drain", (0.25, 0.5, 0.08), (0.675, 0.25, 0.0))
tap.hide_render = drain.hide_render = True
bpy.ops.mesh.primitive_plane_add(size=1.0, location=(0.675, 0.25, 0.001))
grate = bpy.context.active_object
grate.scale = (0.25, 0.5, 1.0)
grate.data.materials.append(material("Grate", (0.02, 0.02, 0.025, 1.0), 0.4))
s = tank.hydrobake_fluid
s.inflow_object, s.inflow_velocity = tap, (1.0, 0.0, -0.3)
s.inflow_start, s.inflow_end = 1, FRAME
s.fluid.max_particles = 200000
solids = bpy.data.collections.new("Solids")
scene.collection.children.link(solids)
floor(0.4, 0.25)
compared(tank, None, solids, FRAME, (40, 25, 30),
         [("none", lambda: setattr(s, "outflow_object", None)),
          ("drain", lambda: setattr(s, "outflow_object", drain))],
         (0.4, -1.05, 0.86), 62, out, "fluid_outflow")
