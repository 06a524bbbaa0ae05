"""A bake from before files were named after their bake (``normal_0001.exr``, no file_tag in
its manifest): Resume continues it under the same names, and the glass shows it."""
import os

import bpy

import in_blender

in_blender.enable()

from hydrobake.core.bake import BakeCache  # noqa: E402

s = in_blender.baked_glass(os.path.join(in_blender.args()[0], "old.blend"))
cache = BakeCache(s.bake_folder)
m = cache.read_manifest()
tag = m.pop("file_tag")
assert tag == "old_Glass_rain_", tag
for files in m["frames"].values():  # as the version before tags wrote it
    for name in list(files):
        os.rename(cache.path(name), cache.path(name[len(tag):]))
        files[name[len(tag):]] = files.pop(name)
cache.write_manifest(m)
assert cache.verify() == []
s.frame_end = 3
assert bpy.ops.hydrobake.bake(effect="rain", object_name="Glass", resume=True) == {"FINISHED"}
m = cache.read_manifest()
assert "file_tag" not in m and m["complete"] and sorted(m["frames"]) == ["1", "2", "3"], m
names = sorted(n for files in m["frames"].values() for n in files)
assert all(not n.startswith(tag) for n in names), names
assert sorted(os.listdir(s.bake_folder)) == sorted(names + ["manifest.json"] + [
    c["file"] for c in m["checkpoints"].values()]), os.listdir(s.bake_folder)
img = bpy.data.images["HBK_Glass_rain_normal"]
assert img.source == "SEQUENCE" and os.path.samefile(bpy.path.abspath(img.filepath),
                                                     cache.path("normal_0001.exr")), img.filepath
print("OLD FILE NAMES OK")
