"""A bake of an object in a scene other than the window's (batch, run_examples, farm) reads that
scene's animation and places: the example's wipers sweep, they are not frozen at their rest
angle, and the fluid's Paint Brush paints where it is, not at the origin (the file holds
identity matrices for scenes never shown). Also after a script set a frame on that scene first,
which builds its depsgraph without making it the one evaluation writes back through."""
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

fluid = bpy.data.scenes["Fluid"]
fluid.frame_set(2)  # a script's own frame_set first: the graph is built, inactive
fluid.frame_set(1)
brush = bpy.data.objects["Paint Brush"]
assert fluid.frame_current == 1 and tuple(brush.matrix_world.translation) == (0.0, 0.0, 0.0)
job = jobs.Job(bpy.context, bpy.data.objects["Tank"], "fluid", frames=(1, 2), scene=fluid)
(texture, centre, radius, falloff), = job.runner.effect.inputs["paint"][1]
assert max(abs(a - b) for a, b in zip(centre, brush.location)) < 1e-6, (centre, brush.location)
job.runner.effect.close()
print("OTHER SCENE OK", [round(angles[f][0], 1) for f in (1, 12, 24)])
