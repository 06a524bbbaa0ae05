"""Times what a snow bake does on the main thread before its thread starts, on a 61k-vertex
sphere (an ico sphere under a Subdivision) over frames 1-100: still, and under a Wave (a shape
that changes every frame, sampled frame by frame). Also the same frames stepped alone, and
stepped with the shape read, which shows what the sampling adds to Blender's own evaluation.

    BLENDER_USER_SCRIPTS=<dir holding addons/hydrobake> blender -b --factory-startup \\
        --python-exit-code 1 --python docs/scripts/snow_prepare_time.py -- OUTDIR [wave]
"""
import os
import sys
import time

import addon_utils
import bpy

args = sys.argv[sys.argv.index("--") + 1:]
addon_utils.enable("hydrobake", default_set=True)
from hydrobake.blender import jobs  # noqa: E402
from hydrobake.blender.bridge import animation, mesh_data  # noqa: E402
from hydrobake.blender.bridge.depsgraph import evaluated  # noqa: E402

bpy.ops.wm.save_as_mainfile(filepath=os.path.join(os.path.abspath(args[0]), "prepare.blend"))
bpy.data.objects.remove(bpy.data.objects["Cube"])
bpy.ops.mesh.primitive_ico_sphere_add(subdivisions=6)
obj = bpy.context.active_object
obj.modifiers.new("Smooth", "SUBSURF").levels = 1
if "wave" in args[1:]:
    obj.modifiers.new("Wave", "WAVE").height = 0.05
s = obj.hydrobake_snow
s.enabled, s.use_scene_range, s.frame_start, s.frame_end = True, False, 1, 100
s.flake_density, s.snow.texture_width, s.snow.texture_height = 100.0, 256, 256
bpy.context.view_layer.update()  # the first evaluation, which a session has done already

t = time.perf_counter()
job = jobs.Job(bpy.context, obj, "snow")
prepare = time.perf_counter() - t
inputs = job.runner.effect.inputs
job.runner.effect.close()
t = time.perf_counter()
animation.per_frame(bpy.context.scene, 1, 100, lambda f: None)
stepped = time.perf_counter() - t
t = time.perf_counter()
animation.per_frame(bpy.context.scene, 1, 100, lambda f: mesh_data.shape(obj, evaluated()))
sampled = time.perf_counter() - t
print(f"PREPARE {len(inputs['positions'])} vertices, {len(inputs.get('frame_positions', {}))} "
      f"shapes: prepare {prepare:.2f} s; 100 frames stepped {stepped:.2f} s, stepped and "
      f"read {sampled:.2f} s")
