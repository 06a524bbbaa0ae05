"""Bake records that do not own their bake: a Shift+D copy of a baked pool holds the
original's record (folder, name, is_baked), and freeing or re-baking the copy must leave the
original's files and wiring whole; a new object given a renamed pool's old name must not
take that pool's bake (its files and wiring still go by the name) and is refused by name. A
baked copy of a fluid domain makes its own surface and Volume, and one of a displaced pool
keeps none of the original's modifiers."""
import os

import bpy

import in_blender

in_blender.enable()
from hydrobake.blender.bridge import materials  # noqa: E402
from hydrobake.core.bake.cache import frame_path  # noqa: E402

in_blender.empty_file("copies.blend")
floor = in_blender.new_plane("Floor")
floor.scale, floor.location = (6.0, 3.0, 1.0), (0.0, 0.0, -0.5)
fmat = in_blender.node_material("Tiles")
floor.data.materials.append(fmat)
pool = in_blender.new_plane("Pool")
s = pool.hydrobake_caustics
s.enabled, s.ground_object = True, floor
s.use_scene_range, s.frame_start, s.frame_end = False, 1, 2
s.water.width, s.map_resolution = 16, 32


def owners():
    return sorted(n["hydrobake_owner"] for n in fmat.node_tree.nodes
                  if n.get("hydrobake") == "caustics.multiply")


assert bpy.ops.hydrobake.bake(effect="caustics", object_name="Pool") == {"FINISHED"}
folder = s.bake_folder
copy = in_blender.duplicate(pool)
copy.location.x = 3.0
c = copy.hydrobake_caustics
assert copy.name == "Pool.001" and c.is_baked and c.bake_folder == folder  # Blender copied it
# Resuming the copy would continue the original's bake: refused.
try:
    bpy.ops.hydrobake.bake(effect="caustics", object_name=copy.name, resume=True)
    raise AssertionError("resume of a copied record was not refused")
except RuntimeError as exc:
    assert "copy of Pool's" in str(exc), str(exc)
# Free on the copy forgets its record only.
assert bpy.ops.hydrobake.free_bake(effect="caustics", object_name=copy.name) == {"FINISHED"}
assert not c.is_baked and c.bake_folder == "" and "baked_as" not in c
assert s.is_baked and os.path.isfile(frame_path(folder, "caustics", 1, "exr"))
assert owners() == ["Pool"] and materials.tagged(pool.active_material.node_tree,
                                                 "caustics.surface") is not None
# A re-bake of a fresh copy (record still copied) makes its own bake beside the original's.
second = in_blender.duplicate(pool)
second.location.x = -3.0
assert second.hydrobake_caustics.is_baked
assert bpy.ops.hydrobake.bake(effect="caustics", object_name=second.name) == {"FINISHED"}
assert second.hydrobake_caustics.bake_folder != folder
assert os.path.isfile(frame_path(folder, "caustics", 1, "exr")) and s.is_baked
assert owners() == sorted(["Pool", second.name]), owners()

# Renamed, then a newcomer takes the old name: its bake is refused, naming the holder.
pool.name = "PoolA"
newcomer = in_blender.new_plane("Pool")
newcomer.hydrobake_caustics.enabled = True
n = newcomer.hydrobake_caustics
n.ground_object, n.use_scene_range, n.frame_start, n.frame_end = floor, False, 1, 2
n.water.width, n.map_resolution = 16, 32
try:
    bpy.ops.hydrobake.bake(effect="caustics", object_name="Pool")
    raise AssertionError("a newcomer with a baked object's old name was not refused")
except RuntimeError as exc:
    assert "PoolA records a caustics bake made under this name" in str(exc), str(exc)
assert os.path.isfile(frame_path(folder, "caustics", 1, "exr")) and owners().count("Pool") == 1
# Re-baking PoolA moves its bake to its new name; then the newcomer may bake.
assert bpy.ops.hydrobake.bake(effect="caustics", object_name="PoolA") == {"FINISHED"}
assert bpy.ops.hydrobake.bake(effect="caustics", object_name="Pool") == {"FINISHED"}
assert owners() == sorted(["Pool", "PoolA", second.name]), owners()

# Shift+D, then the original renamed: the bake was recorded on the original, so it resumes,
# its Free unwires its own material (the copy keeps the files), and the copy's Free removes
# them.
floor2 = in_blender.new_plane("Floor2")
floor2.scale, floor2.location = (3.0, 3.0, 1.0), (0.0, 10.0, -0.5)
orig = in_blender.new_plane("Orig")
orig.location.y = 10.0
water = in_blender.node_material("OrigWater")
orig.data.materials.append(water)
o = orig.hydrobake_caustics
o.enabled, o.ground_object, o.use_scene_range, o.frame_start, o.frame_end = \
    True, floor2, False, 1, 2
o.water.width, o.map_resolution = 16, 32
assert bpy.ops.hydrobake.bake(effect="caustics", object_name="Orig") == {"FINISHED"}
ofolder = o.bake_folder
twin = in_blender.duplicate(orig)
twin.material_slots[0].material = water.copy()  # a material of its own
orig.name = "Renamed"
o.frame_end = 3
assert bpy.ops.hydrobake.bake(effect="caustics", object_name="Renamed", resume=True) == \
    {"FINISHED"}
assert os.path.isfile(frame_path(ofolder, "caustics", 3, "exr"))
assert bpy.ops.hydrobake.free_bake(effect="caustics", object_name="Renamed") == {"FINISHED"}
assert not any(n.get("hydrobake") for n in water.node_tree.nodes)
assert os.path.isdir(ofolder) and twin.hydrobake_caustics.is_baked
assert bpy.ops.hydrobake.free_bake(effect="caustics", object_name=twin.name) == {"FINISHED"}
assert not os.path.exists(ofolder)

# A resume stays in its folder but is wired under the name the pool has now: where another
# pool's bake was made under that name it is refused, as a new bake is (monkey --more
# --delete-baked 1560: the resume took the other pool's made material and left a slot).
pools = []
for i, name in enumerate(("ResA", "ResB")):
    p = in_blender.new_plane(name)
    p.location.y = 20.0 + 3 * i
    r = p.hydrobake_caustics
    r.enabled, r.use_scene_range, r.frame_start, r.frame_end = True, False, 1, 2
    r.water.width, r.map_resolution = 16, 32
    assert bpy.ops.hydrobake.bake(effect="caustics", object_name=name) == {"FINISHED"}
    pools.append(p)
pools[1].name = "ResC"
pools[0].name = "ResB"
try:
    bpy.ops.hydrobake.bake(effect="caustics", object_name="ResB", resume=True)
    raise AssertionError("a resume under another pool's baked name was not refused")
except RuntimeError as exc:
    assert "ResB: ResC records a caustics bake made under this name" in str(exc), exc
assert pools[0].material_slots[0].material.name == "HBK_ResA_water"  # its wiring untouched
pools[0].name = "ResA"
for p in pools:
    assert bpy.ops.hydrobake.free_bake(effect="caustics", object_name=p.name) == {"FINISHED"}
    assert not p.material_slots, [s.material for s in p.material_slots]

# A Shift+D copy given the name the original's bake was made under (the original renamed
# away) is refused as a newcomer is. Before, its copied record let it through as a re-bake of
# its own, into the original's folder and material.
sw = in_blender.new_plane("Sw")
sw.location.y = 30.0
w = sw.hydrobake_caustics
w.enabled, w.use_scene_range, w.frame_start, w.frame_end = True, False, 1, 2
w.water.width, w.map_resolution = 16, 32
assert bpy.ops.hydrobake.bake(effect="caustics", object_name="Sw") == {"FINISHED"}
swfolder, swmat = w.bake_folder, sw.material_slots[0].material.name
stamp = os.stat(frame_path(swfolder, "caustics", 1, "exr")).st_mtime_ns
dup = in_blender.duplicate(sw)
sw.name, dup.name = "SwA", "Sw"
assert dup.name == "Sw" and dup.hydrobake_caustics.bake_folder == swfolder
try:
    bpy.ops.hydrobake.bake(effect="caustics", object_name="Sw")
    raise AssertionError("a renamed copy's bake over its original's was not refused")
except RuntimeError as exc:
    assert "Sw: SwA records a caustics bake made under this name" in str(exc), exc
assert os.stat(frame_path(swfolder, "caustics", 1, "exr")).st_mtime_ns == stamp
assert w.bake_folder == swfolder and sw.material_slots[0].material.name == swmat
# Freed there first (the files stay for the copy's record), the copy's bake is its own.
assert bpy.ops.hydrobake.free_bake(effect="caustics", object_name="SwA") == {"FINISHED"}
assert bpy.ops.hydrobake.bake(effect="caustics", object_name="Sw") == {"FINISHED"}
assert not w.is_baked and dup.hydrobake_caustics.is_baked

# After the file is opened again (new addresses), a bake's holder is known again.
from hydrobake.blender import jobs  # noqa: E402
assert bpy.ops.hydrobake.bake(effect="caustics", object_name="Renamed") == {"FINISHED"}
bpy.ops.wm.save_mainfile()
bpy.ops.wm.open_mainfile(filepath=bpy.data.filepath)
again = bpy.data.objects["Renamed"]
s = again.hydrobake_caustics
assert s.is_baked and s[jobs.HOLDER] == str(again.as_pointer())

# A copy (Alt+D) of a baked fluid domain, baked: its own surface and Volume; the original's
# still show the original's bake (the copy's record named them, and its bake took them).
domain, _fill, fs = in_blender.dam_break((12, 6, 6))
assert bpy.ops.hydrobake.bake(effect="fluid", object_name="Domain") == {"FINISHED"}
surface, volume = bpy.data.objects["HBK_Domain_surface"], bpy.data.objects["HBK_Domain_volume"]
shown = surface["hydrobake_sequence"], volume.data.filepath
twin = in_blender.duplicate(domain, linked=True)
assert bpy.ops.hydrobake.bake(effect="fluid", object_name=twin.name) == {"FINISHED"}
assert (surface["hydrobake_sequence"], volume.data.filepath) == shown, "the copy took them"
own = bpy.data.objects[f"HBK_{twin.name}_volume"].data.filepath
assert os.path.realpath(bpy.path.abspath(own)).startswith(
    os.path.realpath(twin.hydrobake_fluid.bake_folder)), own

# A displaced pool with a projector, copied (Shift+D: the copy holds its record and its
# modifiers) and the copy baked without them (a script changes a baked object's settings):
# the copy keeps nothing of the original's, and once both are freed nothing is left.
deep = in_blender.new_plane("Deep")
d = deep.hydrobake_caustics
d.enabled, d.displace_surface, d.projector = True, True, True
d.use_scene_range, d.frame_start, d.frame_end = False, 1, 2
d.water.width, d.map_resolution = 16, 32
assert bpy.ops.hydrobake.bake(effect="caustics", object_name="Deep") == {"FINISHED"}
twin = in_blender.duplicate(deep)
assert twin.modifiers.get("HBK Displace") is not None  # copied with the object
twin.hydrobake_caustics.displace_surface = twin.hydrobake_caustics.projector = False
assert bpy.ops.hydrobake.bake(effect="caustics", object_name=twin.name) == {"FINISHED"}
assert not [m.name for m in twin.modifiers if m.name.startswith("HBK")], list(twin.modifiers)
assert f"HBK_{twin.name}_projector" not in bpy.data.objects
for name in ("Deep", twin.name):
    assert bpy.ops.hydrobake.free_bake(effect="caustics", object_name=name) == {"FINISHED"}
left = [b.name for blocks in (bpy.data.objects, bpy.data.textures, bpy.data.images,
                              bpy.data.lights) for b in blocks if b.name.startswith("HBK_Deep")]
assert not left, left
# Copied again and the copy baked with its Displace: the copy's heights go into a texture of
# its own. The Displace copied with the object shared the original's texture, and the copy's
# bake put its own heights there: the original's water moved with the copy's waves, and once
# the copy was freed it read files that were gone (monkey --scene --external 1031).
assert bpy.ops.hydrobake.bake(effect="caustics", object_name="Deep") == {"FINISHED"}
twin = in_blender.duplicate(deep)
assert bpy.ops.hydrobake.bake(effect="caustics", object_name=twin.name) == {"FINISHED"}
mine, theirs = deep.modifiers["HBK Displace"].texture, twin.modifiers["HBK Displace"].texture
assert mine != theirs and mine.image.name == "HBK_Deep_height", (mine, theirs, mine.image)
assert theirs.image.name == f"HBK_{twin.name}_height", theirs.image
assert bpy.ops.hydrobake.free_bake(effect="caustics", object_name=twin.name) == {"FINISHED"}
assert mine.image.name == "HBK_Deep_height" and os.path.exists(
    bpy.path.abspath(mine.image.filepath)), mine.image.filepath
assert bpy.ops.hydrobake.free_bake(effect="caustics", object_name="Deep") == {"FINISHED"}
left = [b.name for blocks in (bpy.data.objects, bpy.data.textures, bpy.data.images,
                              bpy.data.lights) for b in blocks if b.name.startswith("HBK_Deep")]
assert not left, left
# The same with the Displace renamed before the copy (monkey 790, every flag but --farm): the
# copy's bake took the renamed one for another's and added a second Displace, so its water
# was displaced twice, once by the original's heights, and that one stayed after the copy's
# Free, reading files the original's Free then removed.
assert bpy.ops.hydrobake.bake(effect="caustics", object_name="Deep") == {"FINISHED"}
deep.modifiers["HBK Displace"].name = "Waves"
twin = in_blender.duplicate(deep)
assert bpy.ops.hydrobake.bake(effect="caustics", object_name=twin.name) == {"FINISHED"}
displaces = [m for m in twin.modifiers if m.type == "DISPLACE"]
assert len(displaces) == 1 and displaces[0].texture.image.name == f"HBK_{twin.name}_height", \
    [(m.name, m.texture.name) for m in displaces]
assert deep.modifiers["Waves"].texture.image.name == "HBK_Deep_height"
for name in (twin.name, "Deep"):
    assert bpy.ops.hydrobake.free_bake(effect="caustics", object_name=name) == {"FINISHED"}
assert not [m.name for o in (deep, twin) for m in o.modifiers if m.type == "DISPLACE"]
left = [b.name for blocks in (bpy.data.objects, bpy.data.textures, bpy.data.images,
                              bpy.data.lights) for b in blocks if b.name.startswith("HBK_Deep")]
assert not left, left
print("COPIED AND RENAMED OK")
