"""A bake of the scene ``blender -b FILE --scene NAME`` opened (a farm's or a script's batch
bake) reads that scene's animation and places, though Blender made it the window's scene
without making its depsgraph the one evaluation writes back through: the example's wipers
sweep, and the fluid's Paint Brush paints where it is, not at the origin (the file holds
identity matrices for scenes it was not saved showing)."""
import bpy

import in_blender

in_blender.enable()
from hydrobake.blender import jobs  # noqa: E402

scene = bpy.context.scene
if scene.name == "Rain":
    glass = bpy.data.objects["Windshield"]
    glass.hydrobake_rain.rain.cell_size = 0.02  # coarse: only the inputs matter here
    job = jobs.Job(bpy.context, glass, "rain", frames=(1, 24))
    angles = job.runner.effect.wipers
    # The example's blades: rest 8 degrees, sweep 110, period 2 s at 24 fps.
    assert abs(angles[1][0] - 8.0) < 2.0 and angles[24][0] > 100.0, (angles[1], angles[24])
else:
    assert scene.name == "Fluid", scene.name
    brush = bpy.data.objects["Paint Brush"]
    job = jobs.Job(bpy.context, bpy.data.objects["Tank"], "fluid", frames=(1, 2))
    (texture, centre, radius, falloff), = job.runner.effect.inputs["paint"][1]
    assert max(abs(a - b) for a, b in zip(centre, brush.location)) < 1e-6, (centre,
                                                                            brush.location)
job.runner.effect.close()
print("COMMAND LINE SCENE OK", scene.name)
