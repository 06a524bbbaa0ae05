"""Saved As with Remap Relative off into a folder that holds an older version of the shot,
its bakes under the same names: Blender keeps the relative paths as they were, which now lead
to the older bakes. The file's images keep showing its own bakes in the session (monkey
--more --elsewhere --relations 204, where the save then freed the older bake and the glass
lost its drops)."""
import os
import shutil

import bpy

import in_blender
import fixture_wave

in_blender.enable()
fixture_wave.install()

tmp = in_blender.args()[0]
a, b = os.path.join(tmp, "a"), os.path.join(tmp, "b")
os.makedirs(a)
os.makedirs(b)
bpy.ops.wm.save_as_mainfile(filepath=os.path.join(a, "shot.blend"))
wave = in_blender.new_plane("Glass").hydrobake_testwave
wave.enabled = True
bpy.context.scene.frame_start, bpy.context.scene.frame_end = 1, 3
assert bpy.ops.hydrobake.bake(effect="testwave", object_name="Glass") == {"FINISHED"}
bpy.ops.wm.save_mainfile()
# The older version of the shot in b: a bake folder of the same name.
folder = os.path.relpath(os.path.normpath(bpy.path.abspath(wave.bake_folder)), a)
shutil.copytree(os.path.join(a, folder), os.path.join(b, folder))


def shown():
    return {i.name: os.path.normpath(bpy.path.abspath(i.filepath))
            for i in bpy.data.images if i.filepath}


before = shown()
assert before and all(p.startswith(os.path.join(a, "")) for p in before.values()), before
bpy.ops.wm.save_as_mainfile(filepath=os.path.join(b, "shot.blend"), relative_remap=False)
assert bpy.data.images[next(iter(before))].filepath.startswith("//"), "relative, as saved"
assert shown() == before, (shown(), before)
assert wave.bake_folder.startswith(os.path.join(a, "")), wave.bake_folder  # the record too
print("SAVED OVER OLDER BAKE OK")
