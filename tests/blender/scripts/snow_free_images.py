"""Free Bake of snow removes the coverage and depth images Bake loaded (HBK_<object>_snow_*),
also when the object was renamed after its bake."""
import os

import bpy

import in_blender

in_blender.enable()

tmp = in_blender.args()[0]
bpy.ops.wm.save_as_mainfile(filepath=os.path.join(tmp, "images.blend"))
cube = bpy.data.objects["Cube"]
s = in_blender.snow(cube, (1, 2), 20, 64)
before = sorted(i.name for i in bpy.data.images)
assert bpy.ops.hydrobake.bake(effect="snow", object_name="Cube") == {"FINISHED"}
assert {"HBK_Cube_snow_coverage", "HBK_Cube_snow_depth"} <= set(bpy.data.images.keys())
cube.name = "Block"
assert bpy.ops.hydrobake.free_bake(effect="snow", object_name="Block") == {"FINISHED"}
after = sorted(i.name for i in bpy.data.images)
assert after == before, (before, after)
print("SNOW FREE IMAGES OK")
