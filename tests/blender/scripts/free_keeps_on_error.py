"""Free Bake unwires before it deletes: when unwiring fails (here made to), the operator
reports it and the bake's files and record stay as they were, so nothing records a bake that
is gone; a second Free then frees it."""
import os

import bpy

import in_blender

in_blender.enable()
from hydrobake.blender import effects  # noqa: E402

s = in_blender.baked_glass("keep.blend")
folder = bpy.path.abspath(s.bake_folder)
files = sorted(os.listdir(folder))

rain = effects.get("rain")
real = rain.remove


def broken(cls, context, obj, settings):
    raise RuntimeError("made to fail")


rain.remove = classmethod(broken)
try:
    bpy.ops.hydrobake.free_bake(effect="rain", object_name="Glass")
except RuntimeError as exc:
    assert "could not unwire the bake" in str(exc) and "files and record are kept" in str(exc), exc
else:
    raise AssertionError("Free reported no error")
rain.remove = real
assert s.is_baked and sorted(os.listdir(folder)) == files, os.listdir(folder)
assert bpy.ops.hydrobake.free_bake(effect="rain", object_name="Glass") == {"FINISHED"}
assert not s.is_baked and not os.path.exists(folder)
print("FREE KEEPS ON ERROR OK")
