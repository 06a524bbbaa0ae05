"""A bake another .blend made in the very folder a bake would go to is that file's: two files
of one name in two folders sharing an absolute Cache Folder, or a file saved elsewhere under
its own name. A bake there is refused naming the file, and Free Bake lets go of it and keeps
its files. A copy of the whole project, whose bakes were made in the original's folders, owns
its copies: it re-bakes and frees them, and the original's stay."""
import os
import shutil

import bpy

import in_blender

in_blender.enable()
from hydrobake.blender import jobs  # noqa: E402

tmp = in_blender.args()[0]


def glass(cache_dir=""):
    o = in_blender.uv_plane("Glass")
    s = o.hydrobake_rain
    s.enabled, s.use_scene_range, s.frame_start, s.frame_end = True, False, 1, 2
    s.rain.cell_size, s.cache_dir = 0.05, cache_dir
    return s


def bake():
    return bpy.ops.hydrobake.bake(effect="rain", object_name="Glass")


def listing(folder):
    return {n: os.path.getmtime(os.path.join(folder, n)) for n in os.listdir(folder)}


# One absolute Cache Folder for sh010/lighting.blend and sh020/lighting.blend.
shared = os.path.join(tmp, "cache", "")
for shot in ("sh010", "sh020"):
    os.makedirs(os.path.join(tmp, shot))
first = os.path.join(tmp, "sh010", "lighting.blend")
in_blender.empty_file(os.path.join("sh010", "lighting.blend"))
s = glass(shared)
assert bake() == {"FINISHED"}
bpy.ops.wm.save_mainfile()
folder = s.bake_folder
assert folder.startswith(shared), folder
kept = listing(folder)

bpy.ops.wm.save_as_mainfile(filepath=os.path.join(tmp, "sh020", "lighting.blend"))
s = bpy.data.objects["Glass"].hydrobake_rain
try:
    bake()
    raise AssertionError("baked over another file's bake")
except RuntimeError as exc:
    assert f"{folder} holds a rain bake that {first} made, which may still show it: free it " \
        "there, or set another Cache Folder" in str(exc), exc
assert listing(folder) == kept
assert bpy.ops.hydrobake.free_bake(effect="rain", object_name="Glass") == {"FINISHED"}
assert not s.is_baked and listing(folder) == kept
assert jobs.kept_after_free(folder) == (
    f"{first} made this bake and may still show it: its files in {folder} are kept (free it "
    "there, or delete the folder by hand)")
try:
    bake()
    raise AssertionError("baked over another file's bake once let go of")
except RuntimeError as exc:
    assert "holds a rain bake that" in str(exc), exc
s.cache_dir = os.path.join(tmp, "cache20", "")
assert bake() == {"FINISHED"} and s.bake_folder.startswith(s.cache_dir)
bpy.ops.wm.save_mainfile()
bpy.ops.wm.open_mainfile(filepath=first)
assert jobs.bake_state(bpy.data.objects["Glass"], "rain") == "COMPLETE"
assert listing(folder) == kept
assert bake() == {"FINISHED"}, "the file that made it re-bakes it"
assert bpy.ops.hydrobake.free_bake(effect="rain", object_name="Glass") == {"FINISHED"}
assert not os.path.exists(folder), "the file that made it frees it"

# A project copied whole (relative Cache Folder): the copy's bakes are its own.
os.makedirs(os.path.join(tmp, "pa"))
in_blender.empty_file(os.path.join("pa", "shot.blend"))
glass()
assert bake() == {"FINISHED"}
bpy.ops.wm.save_mainfile()
original = bpy.data.objects["Glass"].hydrobake_rain.bake_folder
shutil.copytree(os.path.join(tmp, "pa"), os.path.join(tmp, "pb"))
bpy.ops.wm.open_mainfile(filepath=os.path.join(tmp, "pb", "shot.blend"))
s = bpy.data.objects["Glass"].hydrobake_rain
copy = s.bake_folder
assert copy.startswith(os.path.join(tmp, "pb", "")) and jobs.made_elsewhere(copy) is None
assert bake() == {"FINISHED"}
assert bpy.ops.hydrobake.free_bake(effect="rain", object_name="Glass") == {"FINISHED"}
assert not os.path.exists(copy) and os.listdir(original)
print("OTHER FILES BAKES OK")
