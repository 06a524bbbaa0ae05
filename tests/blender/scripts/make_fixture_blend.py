"""Saves a .blend with two objects that have the fixture effect enabled."""
import os

import bpy

import in_blender
import fixture_wave

in_blender.enable()
fixture_wave.install()
out = in_blender.args()[0]
for name in ("Glass", "Rear"):
    in_blender.new_plane(name).hydrobake_testwave.enabled = True
bpy.context.scene.frame_start, bpy.context.scene.frame_end = 1, 3
bpy.ops.wm.save_as_mainfile(filepath=out)
print("SAVED", out)
