"""Renders docs/images/fluid_swing.png: the Inflow's Source. A tap (a ball of 3 cm) 30 cm over
a shallow pool pours down at 0.5 m/s while it is swept along the tank at 1.1 m/s over frames
1-12; fluid textured at 40 cells along the tank, rendered in Cycles at frame 10 (or FRAME),
seen from the front. Left, Source 0: the water leaves the tap with the Inflow Velocity alone
and falls straight down where it left, so the tap runs ahead of its own stream and the stream
trails behind it, leaning back. Right, Source 1 (the default): the water also takes on the
tap's motion, so it keeps up with the tap and falls in a column right under it, as water
poured from a moving jug does.

    BLENDER_USER_SCRIPTS=<dir holding addons/hydrobake> blender -b --factory-startup \\
        --python-exit-code 1 --python docs/scripts/fluid_swing.py -- OUTDIR [FRAME]
"""
import os
import sys

import bpy

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from tank_scene import box, compared, floor, start  # noqa: E402

args = sys.argv[sys.argv.index("--") + 1:]
SWEEP, FRAME = 12, int(args[1]) if len(args) > 1 else 10
out = start("swing.blend")
scene = bpy.context.scene
tank = box("Tank", (0.8, 0.4, 0.5), (0.4, 0.2, 0.25))
pool = box("Pool", (0.8, 0.4, 0.04), (0.4, 0.2, 0.02))
bpy.ops.mesh.primitive_uv_sphere_add(radius=0.03, location=(0.1, 0.2, 0.3))
tap = bpy.context.active_object
pool.hide_render = tap.hide_render = True
for frame, x in ((1, 0.1), (SWEEP, 0.6)):
    tap.location.x = x
    tap.keyframe_insert("location", index=0, frame=frame)
for fc in tap.animation_data.action.fcurves:
    for k in fc.keyframe_points:
        k.interpolation = "LINEAR"
s = tank.hydrobake_fluid
s.inflow_object, s.inflow_velocity = tap, (0.0, 0.0, -0.5)
s.inflow_start, s.inflow_end = 1, SWEEP
s.fluid.max_particles = 200000
solids = bpy.data.collections.new("Solids")
scene.collection.children.link(solids)
floor(0.4, 0.2)
compared(tank, pool, solids, FRAME, (40, 20, 25),
         [(f"{v:g}", lambda v=v: setattr(s, "inflow_source", v)) for v in (0.0, 1.0)],
         (0.4, -0.85, 0.3), 82, out, "fluid_swing")
