"""Saves a .blend with two objects that have the fixture effect enabled."""
import os

import bpy

import hbk_test
import fixture_wave

hbk_test.enable()
fixture_wave.install()
out = hbk_test.args()[0]
for name in ("Glass", "Rear"):
    hbk_test.new_plane(name).hydrobake_testwave.enabled = True
bpy.context.scene.frame_start, bpy.context.scene.frame_end = 1, 3
bpy.ops.wm.save_as_mainfile(filepath=out)
print("SAVED", out)
