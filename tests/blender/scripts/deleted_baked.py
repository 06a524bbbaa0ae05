"""Objects deleted while baked (no Free Bake first) leave their wiring in the materials they
showed (taken out then, by a handler, Undo would not bring it back); the panel of an object
given such a material says so, and Remove Deleted Objects' Bakes (File > Clean Up) takes it
out as the Free would have: the materials are as before the bake, the deleted object's own
material copies, flakes and images go, the files stay. A Shift+D copy holding the same bake
keeps it (monkey seed 159); an object later given the deleted one's name frees its files
only once the file no longer shows them."""
import os

import bpy

import in_blender

in_blender.enable()
from hydrobake.blender.bridge import materials  # noqa: E402
from hydrobake.core.bake.cache import frame_path  # noqa: E402

tmp = in_blender.empty_file("deleted_baked.blend")


def tagged(mat):
    return sorted(str(n.get(materials.TAG)) for n in mat.node_tree.nodes
                  if n.get(materials.TAG)) if mat.node_tree else []


def state(mat):
    bsdf = materials.principled(mat.node_tree) if mat.node_tree else None
    return (mat.use_nodes, sorted(n.name for n in mat.node_tree.nodes) if mat.node_tree else
            None, len(mat.node_tree.links) if mat.node_tree else 0,
            sorted(k for k in mat.keys() if k.startswith("hydrobake") and k != "hydrobake_snow"),
            tuple(round(bsdf.inputs[k].default_value, 6) for k in ("Transmission", "IOR"))
            if bsdf else None)


def bake(name, effect):
    assert bpy.ops.hydrobake.bake(effect=effect, object_name=name) == {"FINISHED"}
    obj = bpy.data.objects[name]
    return bpy.path.abspath(getattr(obj, f"hydrobake_{effect}").bake_folder)


def delete(name):
    bpy.data.objects.remove(bpy.data.objects[name])
    bpy.context.view_layer.update()  # what the UI does after a delete


def remove(effect=""):
    return bpy.ops.hydrobake.remove_deleted_bakes(effect=effect)


def panel_says(obj, effect):
    """The labels and operators the effect's panel draws for ``obj``."""
    return [(name, (args[0] if args else "") or kw.get("text", ""))
            for name, args, kw in in_blender.panel_calls(obj, effect)
            if name in ("label", "operator")]


def glass(name, mat):
    o = in_blender.uv_plane(name)
    o.location.x = 3 * len(bpy.data.objects)
    if mat is not None:
        o.data.materials.append(mat)
    s = o.hydrobake_rain
    s.enabled, s.rain.cell_size = True, 0.05
    s.use_scene_range, s.frame_start, s.frame_end = False, 1, 2
    return o


# Snow in its object's own material, whose nodes were off, given to another object after the
# delete: its panel says so; Remove gives the material back, takes the flakes and images.
felt = bpy.data.materials.new("Felt")
snowy = in_blender.uv_plane("Snowy")
snowy.data.materials.append(felt)
in_blender.snow(snowy, (1, 2), 40.0, 16).write_flakes = True
before = state(felt)
folder = bake("Snowy", "snow")
rug = in_blender.uv_plane("Rug")
assert not [x for x in panel_says(rug, "snow") if "deleted" in x[1]]
delete("Snowy")
assert tagged(felt) and "HBK_Snowy_flakes" in bpy.data.objects, "the delete changed the file"
rug.data.materials.append(felt)
said = panel_says(rug, "snow")
assert ("label", "Shows the snow of deleted 'Snowy'") in said, said
assert ("operator", "hydrobake.remove_deleted_bakes") in said, said
assert remove("snow") == {"FINISHED"}
assert not tagged(felt), f"the deleted object's snow stayed in Felt: {tagged(felt)}"
# (Nodes once on stay in the file while off, as after a Free Bake.)
assert state(felt)[::3] == before[::3], f"Felt is {state(felt)}, was {before}"
assert "HBK_Snowy_flakes" not in bpy.data.objects
assert not [i.name for i in bpy.data.images if i.name.startswith("HBK_Snowy")]
assert os.path.isfile(os.path.join(folder, "manifest.json")), "the deleted object's files went"
assert not [x for x in panel_says(rug, "snow") if "deleted" in x[1]]
assert remove() == {"CANCELLED"}, "a second Remove found something"

# Rain on a glass sharing its material with a pane: the glass's own copy goes, the shared
# material was never wired.
shared = in_blender.node_material("GlassMat")
before = state(shared)
glass("Glass", shared)
glass("Pane", shared)
bake("Glass", "rain")
assert tagged(bpy.data.materials["GlassMat (Glass)"]) and not tagged(shared)
delete("Glass")
assert remove() == {"FINISHED"}
assert "GlassMat (Glass)" not in bpy.data.materials, "the deleted glass's copy stayed"
assert state(shared) == before and [s.material for s in bpy.data.objects["Pane"].material_slots] \
    == [shared]

# A glass deleted while baked and another object given its name: the newcomer's Free (it
# records no bake) leaves the deleted glass's files while the file shows them (undo brings
# the glass back with them), and removes them once Remove has taken them out of the file
# (monkey --more --delete-baked 1673).
lens_folder = bake(glass("Lens", in_blender.node_material("LensMat")).name, "rain")
delete("Lens")
newcomer = glass("Lens", None)
assert bpy.ops.hydrobake.free_bake(effect="rain", object_name="Lens") == {"FINISHED"}
assert os.path.isfile(frame_path(lens_folder, "normal", 1, "exr")), \
    "a Free of an object of the same name removed the deleted glass's files"
assert remove("rain") == {"FINISHED"}
assert bpy.ops.hydrobake.free_bake(effect="rain", object_name="Lens") == {"FINISHED"}
assert not os.path.exists(os.path.join(lens_folder, "manifest.json")), \
    "the files nothing shows stayed"
bpy.data.objects.remove(newcomer)

# A pool: the floor's caustics go with the delete (a handler; the floor's material changes
# with it, and Undo brings them back), the water's values and wiring with Remove.
ground = in_blender.uv_plane("Ground")
ground.location.z = -0.5
ground.data.materials.append(in_blender.node_material("Tiles"))
water = in_blender.uv_plane("Water")
water_mat = in_blender.node_material("WaterMat")
water.data.materials.append(water_mat)
before = state(water_mat)
c = water.hydrobake_caustics
c.enabled, c.ground_object = True, ground
c.use_scene_range, c.frame_start, c.frame_end = False, 1, 2
c.water.width, c.map_resolution = 16, 32
bake("Water", "caustics")
assert state(water_mat) != before and tagged(bpy.data.materials["Tiles"])
delete("Water")
assert not tagged(bpy.data.materials["Tiles"]) and tagged(water_mat)
assert remove("caustics") == {"FINISHED"}
assert state(water_mat) == before, f"WaterMat is {state(water_mat)}, was {before}"

# A glass with no material (the bake made one), Shift+D copied, the original deleted: the
# copy holds the bake's record and still shows it; its Free takes everything.
g = glass("Screen", None)
bake("Screen", "rain")
copy = in_blender.duplicate(g)
delete("Screen")
assert remove() == {"CANCELLED"}, "Remove took the bake a copy holds"
made = bpy.data.materials["HBK_Screen_glass"]
assert tagged(made) and copy.hydrobake_rain.is_baked, "the copy's bake went with the original"
assert bpy.ops.hydrobake.free_bake(effect="rain", object_name=copy.name) == {"FINISHED"}
assert "HBK_Screen_glass" not in bpy.data.materials
assert not [m.name for m in bpy.data.materials if tagged(m)]

try:
    remove("nope")
    raise AssertionError("an unknown effect was taken")
except RuntimeError as exc:
    assert "effect = 'nope': must be one of caustics" in str(exc), exc
assert "draw_cleanup_menu" in [f.__name__ for f in
                               bpy.types.TOPBAR_MT_file_cleanup._dyn_ui_initialize()]


def shown_missing():
    return [(b.name, b.filepath) for b in (*bpy.data.images, *bpy.data.volumes)
            if b.name.startswith("HBK") and b.users and
            not os.path.exists(bpy.path.abspath(b.filepath))]


# A deleted glass's bake still shown by its material on another object, the file saved into
# other folders with Remap Relative off: no object records the bake, yet its images are
# found again, after a Save As and in a copy once opened (monkey --more --delete-baked
# --elsewhere 7017).
for o in list(bpy.data.objects):
    bpy.data.objects.remove(o)
lamp_mat = in_blender.node_material("LampMat")
bake(glass("Lamp", lamp_mat).name, "rain")
delete("Lamp")
in_blender.uv_plane("Shade").data.materials.append(lamp_mat)
assert any(b.name.startswith("HBK_Lamp") for b in bpy.data.images) and not shown_missing()
bpy.ops.wm.save_mainfile()
for sub, copy in (("far", True), ("other", False)):
    os.makedirs(os.path.join(tmp, sub, "deeper"))
    bpy.ops.wm.save_as_mainfile(filepath=os.path.join(tmp, sub, "deeper", "moved.blend"),
                                copy=copy, relative_remap=False)
    assert not shown_missing(), f"after saving into {sub}: {shown_missing()}"
bpy.ops.wm.open_mainfile(filepath=os.path.join(tmp, "far", "deeper", "moved.blend"))
assert not shown_missing(), f"the copy, opened: {shown_missing()}"

# The bake a Shift+D copy took over (its original freed, the copy resumed it after the file
# was opened again) is in the original's folder; the copy deleted, the file still shows it
# there: a new bake of the original is refused until Remove Deleted Objects' Bakes, so that
# it does not change what Undo brings back (monkey --more --delete-baked --elsewhere 7103).
for o in list(bpy.data.objects):
    bpy.data.objects.remove(o)
folder = bake(glass("Pane", None).name, "rain")
in_blender.duplicate(bpy.data.objects["Pane"])
assert bpy.ops.hydrobake.free_bake(effect="rain", object_name="Pane") == {"FINISHED"}
bpy.ops.wm.save_mainfile()
bpy.ops.wm.open_mainfile(filepath=bpy.data.filepath)
assert bpy.ops.hydrobake.bake(effect="rain", object_name="Pane.001", resume=True) == \
    {"FINISHED"}
delete("Pane.001")
kept = sorted(os.listdir(folder))
try:
    bpy.ops.hydrobake.bake(effect="rain", object_name="Pane")
    raise AssertionError("baked over a deleted object's bake the file shows")
except RuntimeError as exc:
    assert f"{folder} holds the rain bake of deleted 'Pane.001', which this file still shows " \
        "(Undo brings it back): take it out with File > Clean Up > Remove Deleted Objects' " \
        "Bakes first, or rename Pane" in str(exc), exc
assert sorted(os.listdir(folder)) == kept and not shown_missing()
assert remove("rain") == {"FINISHED"}
bake("Pane", "rain")
assert bpy.ops.hydrobake.free_bake(effect="rain", object_name="Pane") == {"FINISHED"}
assert not shown_missing(), shown_missing()
print("DELETED BAKED OK")
