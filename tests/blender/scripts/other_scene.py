"""A bake of an object in a scene other than the window's (batch, run_examples, farm) reads that
scene's animation: the example's wipers sweep, they are not frozen at their rest angle."""
import bpy

import in_blender

in_blender.enable()
from hydrobake.blender import jobs  # noqa: E402

rain = bpy.data.scenes["Rain"]
assert bpy.context.scene != rain, bpy.context.scene.name  # the window shows another scene
glass = bpy.data.objects["Windshield"]
s = glass.hydrobake_rain
s.rain.cell_size = 0.02  # coarse: only the inputs matter here
job = jobs.Job(bpy.context, glass, "rain", frames=(1, 24), scene=rain)
angles = job.runner.effect.wipers
# The example's blades: rest 8 degrees, sweep 110, period 2 s at 24 fps.
assert abs(angles[1][0] - 8.0) < 2.0 and angles[24][0] > 100.0, (angles[1], angles[24])
assert bpy.context.scene != rain and rain.frame_current == 1  # nothing left changed
job.runner.effect.close()
print("OTHER SCENE OK", [round(angles[f][0], 1) for f in (1, 12, 24)])
