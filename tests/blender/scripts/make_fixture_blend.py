"""Saves a .blend with two objects that have the fixture effect enabled (Glass and Rear), and
the further objects named after the file: NAME, or !NAME for one whose bake fails to set up."""
import bpy

import in_blender
import fixture_wave

in_blender.enable()
fixture_wave.install()
out, *more = in_blender.args()
for name in ("Glass", "Rear", *more):
    obj = in_blender.new_plane(name.lstrip("!"))
    obj.hydrobake_testwave.enabled = True
    if name.startswith("!"):
        obj["hbk_fixture_fail"] = True
bpy.context.scene.frame_start, bpy.context.scene.frame_end = 1, 3
bpy.ops.wm.save_as_mainfile(filepath=out)
print("SAVED", out)
