"""A bake re-made in another folder replaces the old one, as a re-bake in place does: the old
folder is freed when the new bake is complete and the file saved. A renamed glass whose
re-bake was cancelled keeps its old bake (a partial bake replaces nothing yet) until the
resumed re-bake completes. Free Bake frees the bakes the freed one replaced, saved or not. A
bake sent to another folder on purpose (another Cache Folder, --output) replaces nothing, nor
does one an earlier version of the file made (saved from it as shot_v2.blend), whose Free in
the new version lets go of it and keeps its files."""
import os

import bpy

import in_blender

in_blender.enable()
from hydrobake.blender import jobs  # noqa: E402
from hydrobake.core import errors  # noqa: E402

tmp = in_blender.empty_file("superseded.blend")


def rain_plane(name, frames=3):
    obj = in_blender.uv_plane(name)
    r = obj.hydrobake_rain
    r.enabled, r.use_scene_range, r.frame_start, r.frame_end = True, False, 1, frames
    r.rain.cell_size = 0.05
    return obj, r


def folder(settings=None):
    return os.path.realpath(bpy.path.abspath((settings or s).bake_folder))


glass, s = rain_plane("Glass")


def save():
    bpy.ops.wm.save_mainfile()


def bake_cancelled_after_one_frame(obj):
    job = jobs.Job(bpy.context, obj, "rain")
    job.runner.on_frame = lambda state: job.runner.cancel()
    try:
        job.runner.run()
    except errors.Cancelled:
        pass
    job.finalize(bpy.context)


assert bpy.ops.hydrobake.bake(effect="rain", object_name="Glass") == {"FINISHED"}
first = folder()
glass.name = "Glass2"
bake_cancelled_after_one_frame(glass)
second = folder()
assert second != first and jobs.bake_state(glass, "rain") == "PARTIAL"
save()
assert os.path.isdir(first), "a cancelled re-bake freed the complete one it had not replaced"
assert bpy.ops.hydrobake.bake(effect="rain", object_name="Glass2", resume=True) == {"FINISHED"}
assert folder() == second and jobs.bake_state(glass, "rain") == "COMPLETE"
assert os.path.isdir(first)  # not before the save
save()
assert not os.path.exists(first), "the replaced bake stayed on disk after the save"

# Renamed, then resumed (the bake stays in the folder of the old name), then baked anew:
# the new name's folder replaces the old name's.
pane, p = rain_plane("Pane")
bake_cancelled_after_one_frame(pane)
pane_first = folder(p)
pane.name = "Pane2"
assert bpy.ops.hydrobake.bake(effect="rain", object_name="Pane2", resume=True) == {"FINISHED"}
assert folder(p) == pane_first
assert bpy.ops.hydrobake.bake(effect="rain", object_name="Pane2") == {"FINISHED"}
assert folder(p) != pane_first
save()
assert not os.path.exists(pane_first), "the old name's folder stayed after a resume and re-bake"

# Renamed and re-baked, then freed before any save: the old name's bake, kept until the
# save for the file on disk, goes with it (deleted after, nothing would have freed it).
roof, r = rain_plane("Roof", frames=2)
save()
assert bpy.ops.hydrobake.bake(effect="rain", object_name="Roof") == {"FINISHED"}
roof_first = folder(r)
roof.name = "Roof2"
assert bpy.ops.hydrobake.bake(effect="rain", object_name="Roof2") == {"FINISHED"}
roof_second = folder(r)
assert roof_second != roof_first and os.path.isdir(roof_first)
assert bpy.ops.hydrobake.free_bake(effect="rain", object_name="Roof2") == {"FINISHED"}
assert not os.path.exists(roof_first) and not os.path.exists(roof_second), \
    "Free Bake left the bake the freed one had replaced"
assert "superseded" not in r.keys()
# With a copy (Shift+D) holding the bake too, the first Free lets go of it and the last
# frees it, and the one it replaced with it.
assert bpy.ops.hydrobake.bake(effect="rain", object_name="Roof2") == {"FINISHED"}
roof.name = "Roof3"
assert bpy.ops.hydrobake.bake(effect="rain", object_name="Roof3") == {"FINISHED"}
kept = folder(r)
twin = roof.copy()
bpy.context.scene.collection.objects.link(twin)
assert bpy.ops.hydrobake.free_bake(effect="rain", object_name="Roof3") == {"FINISHED"}
assert os.path.isdir(kept) and os.path.isdir(roof_second), \
    "Free Bake on one of two holders removed their bake or the one it replaced"
assert bpy.ops.hydrobake.free_bake(effect="rain", object_name=twin.name) == {"FINISHED"}
assert not os.path.exists(kept) and not os.path.exists(roof_second)

# Baked to another folder on purpose (--output, another Cache Folder): both stay.
assert bpy.ops.hydrobake.free_bake(effect="rain", object_name="Glass2") == {"FINISHED"}
assert bpy.ops.hydrobake.bake(effect="rain", object_name="Glass2") == {"FINISHED"}
old = folder()
s.cache_dir = os.path.join(tmp, "elsewhere")
assert bpy.ops.hydrobake.bake(effect="rain", object_name="Glass2") == {"FINISHED"}
assert folder() != old
save()
assert os.path.isdir(old) and os.path.isdir(folder())

# Saved as a new version (shot_v2.blend beside the first), renamed and re-baked there: the
# first version still records its bake, which stays, at the save and at Free Bake; a bake the
# new version made itself is replaced as before.
v1 = os.path.join(tmp, "superseded.blend")
bpy.ops.wm.save_as_mainfile(filepath=os.path.join(tmp, "superseded_v2.blend"))
s = bpy.data.objects["Glass2"].hydrobake_rain
first = folder()
bpy.data.objects["Glass2"].name = "Glass3"
assert bpy.ops.hydrobake.bake(effect="rain", object_name="Glass3") == {"FINISHED"}
save()
assert os.path.isdir(first) and os.listdir(first), "the first version's bake was freed"
v2_own = folder()
bpy.data.objects["Glass3"].name = "Glass4"
assert bpy.ops.hydrobake.bake(effect="rain", object_name="Glass4") == {"FINISHED"}
save()
assert not os.path.exists(v2_own) and os.path.isdir(first)
assert bpy.ops.hydrobake.free_bake(effect="rain", object_name="Glass4") == {"FINISHED"}
assert os.path.isdir(first) and os.listdir(first)
bpy.ops.wm.open_mainfile(filepath=v1)
assert jobs.bake_state(bpy.data.objects["Glass2"], "rain") == "COMPLETE"
# Freed in a version saved from it, the first version's bake is let go of, its files kept.
bpy.ops.wm.save_as_mainfile(filepath=os.path.join(tmp, "superseded_v3.blend"))
assert bpy.ops.hydrobake.free_bake(effect="rain", object_name="Glass2") == {"FINISHED"}
assert not bpy.data.objects["Glass2"].hydrobake_rain.is_baked
assert os.path.isdir(first) and os.listdir(first)
assert jobs.kept_after_free(first) == (
    f"{v1} made this bake and may still show it: its files in {first} are kept (free it "
    "there, or delete the folder by hand)"), jobs.kept_after_free(first)
bpy.ops.wm.open_mainfile(filepath=v1)
assert jobs.bake_state(bpy.data.objects["Glass2"], "rain") == "COMPLETE"
assert bpy.ops.hydrobake.free_bake(effect="rain", object_name="Glass2") == {"FINISHED"}
assert not os.path.exists(first)  # freed where it was made
print("SUPERSEDED FOLDERS OK")
