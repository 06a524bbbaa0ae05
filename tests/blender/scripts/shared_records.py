"""Bakes that share a material, a mesh or a record, freed in the orders that once lost data:
two effects in one material (freeing one leaves the other's values, node switch and made
material), linked duplicates with no material, a Glass BSDF's values, a copy made for another
bake keeping its effect's wiring, a Shift+D copy of a renamed pool, a newcomer's Free on a
taken name, a renamed pool resumed under its old folder, a ground changed between bakes, and
a Shift+D copy re-baked after its original was freed (the original's folder goes at the save,
unless the original baked there again)."""
import os

import bpy

import in_blender

in_blender.enable()
from hydrobake.blender.bridge import materials as M  # noqa: E402
from hydrobake.core.bake.cache import frame_path  # noqa: E402

in_blender.empty_file("records.blend")


def plane(name, size=0.5, loc=(0, 0, 0)):
    obj = in_blender.new_plane(name)
    obj.scale, obj.location = (size, size, 1.0), loc
    uv = obj.data.uv_layers.new(name="UVMap")
    for loop, c in zip(uv.data, ((0, 0), (1, 0), (1, 1), (0, 1))):
        loop.uv = c
    return obj


def rain(o):
    s = o.hydrobake_rain
    s.enabled, s.rain.cell_size, s.use_scene_range, s.frame_start, s.frame_end = \
        True, 0.05, False, 1, 1
    return s


def snow(o):
    s = o.hydrobake_snow
    s.enabled, s.use_scene_range, s.frame_start, s.frame_end = True, False, 1, 1
    s.flake_density, s.snow.texture_width, s.snow.texture_height = 200.0, 64, 64
    return s


def caustics(o, ground):
    s = o.hydrobake_caustics
    s.enabled, s.ground_object, s.use_scene_range, s.frame_start, s.frame_end = \
        True, ground, False, 1, 2
    s.water.width, s.map_resolution = 16, 32
    return s


def bake(o, effect, **kw):
    assert bpy.ops.hydrobake.bake(effect=effect, object_name=o.name, **kw) == {"FINISHED"}


def free(o, effect):
    assert bpy.ops.hydrobake.free_bake(effect=effect, object_name=o.name) == {"FINISHED"}


def tags(m):
    return sorted(n["hydrobake"] for n in m.node_tree.nodes if n.get("hydrobake")) \
        if m is not None and m.node_tree else []


def values(m):
    b = M.principled(m.node_tree)
    return [round(b.inputs[k].default_value, 3) for k in ("Transmission", "Roughness", "IOR")]


def floor_material(name, loc):
    f = plane(name, 3.0, loc)
    m = in_blender.node_material(f"{name}Tiles")
    f.data.materials.append(m)
    return f, m


# Rain and snow in one material: freeing snow leaves rain's glass values; a glass with no
# material keeps the one rain made until both are freed; nodes switched on stay on for rain.
g = plane("Glass", loc=(0, 0, 1))
gm = in_blender.node_material("GlassMat")
g.data.materials.append(gm)
rain(g), snow(g)
bake(g, "rain"), bake(g, "snow"), free(g, "snow")
assert values(gm) == [1.0, 0.0, 1.33], values(gm)
free(g, "rain")
assert values(gm) == [0.0, 0.5, 1.45], values(gm)
bare = plane("Bare", loc=(3, 0, 1))
rain(bare), snow(bare)
bake(bare, "rain"), bake(bare, "snow"), free(bare, "snow")
assert bare.active_material is not None and "rain.side" in tags(bare.active_material)
free(bare, "rain")
assert len(bare.material_slots) == 0
off = plane("Off", loc=(6, 0, 1))
om = bpy.data.materials.new("NodesOff")
off.data.materials.append(om)
rain(off), snow(off)
bake(off, "rain"), bake(off, "snow"), free(off, "snow")
assert om.use_nodes and "rain.side" in tags(om)
free(off, "rain")
assert not om.use_nodes

# Linked duplicates without a material: freeing one leaves the other its material and drops.
a = plane("GlassA", loc=(0, 3, 1))
b = bpy.data.objects.new("GlassB", a.data)
b.location = (3, 3, 1)
bpy.context.scene.collection.objects.link(b)
rain(a), rain(b)
bake(a, "rain"), bake(b, "rain"), free(b, "rain")
assert a.material_slots[0].material is not None and "rain.side" in tags(a.material_slots[0].material)
free(a, "rain")
bake(a, "rain"), bake(b, "rain"), free(a, "rain"), free(b, "rain")  # the other order: clean
assert len(a.data.materials) == 0 and len(b.material_slots) == 0, (len(a.data.materials),
                                                                   len(b.material_slots))
assert not [m.name for m in bpy.data.materials if m.name.startswith("HBK_GlassA")]

# Freeing a Shift+D copy that no longer records anything leaves the original's wiring.
pc_floor = plane("PcFloor", 3.0, (0, 10, -0.5))
pc = plane("Pc", 1.0, (0, 10, 0))
caustics(pc, pc_floor)
bake(pc, "caustics")
pc_copy = in_blender.duplicate(pc)
free(pc_copy, "caustics"), free(pc_copy, "caustics")  # the second one has no record at all
assert pc.hydrobake_caustics.is_baked and "caustics.surface" in tags(pc.active_material)
free(pc, "caustics")

# A copy freed before its original takes out what the bake changed on it alone: its
# modifiers and shadow flag (caustics), its glass thickness (rain).
pd_floor = plane("PdFloor", 3.0, (0, 14, -0.5))
pd = plane("Pd", 1.0, (0, 14, 0))
ds = caustics(pd, pd_floor)
ds.displace_surface = True
bake(pd, "caustics")
pd_copy = in_blender.duplicate(pd)
assert "HBK Displace" in pd_copy.modifiers and not pd_copy.visible_shadow
free(pd_copy, "caustics")
assert "HBK Displace" not in pd_copy.modifiers and pd_copy.visible_shadow
assert "hydrobake_shadow" not in pd_copy.keys()
assert "HBK Displace" in pd.modifiers and pd.hydrobake_caustics.is_baked
assert "caustics.surface" in tags(pd.active_material)  # shared with the copy: kept
free(pd, "caustics")
assert "HBK Displace" not in pd.modifiers and pd.visible_shadow
rg = plane("Rg", loc=(6, 14, 1))
rain(rg)
bake(rg, "rain")
rg_copy = in_blender.duplicate(rg)
free(rg_copy, "rain")
assert "HBK Glass Thickness" not in rg_copy.modifiers and "HBK Glass Thickness" in rg.modifiers
free(rg, "rain")

# A Glass BSDF gets its own IOR and roughness back.
gb = plane("GlassBSDF", loc=(6, 3, 1))
bm = in_blender.node_material("GlassShader")
bm.node_tree.nodes.remove(M.principled(bm.node_tree))
shader = bm.node_tree.nodes.new("ShaderNodeBsdfGlass")
shader.inputs["IOR"].default_value, shader.inputs["Roughness"].default_value = 1.52, 0.1
bm.node_tree.links.new(shader.outputs[0], bm.node_tree.nodes["Material Output"].inputs[0])
gb.data.materials.append(bm)
rain(gb)
bake(gb, "rain"), free(gb, "rain")
assert [round(shader.inputs[k].default_value, 3) for k in ("IOR", "Roughness")] == [1.52, 0.1]

# A material shared with another object: the copy keeps snow's wiring when rain is freed.
sm = in_blender.node_material("Shared")
g2, o2 = plane("Glass2", loc=(0, 6, 1)), plane("Other", loc=(3, 6, 1))
g2.data.materials.append(sm), o2.data.materials.append(sm)
rain(g2), snow(g2)
bake(g2, "snow"), bake(g2, "rain"), free(g2, "rain")
assert "snow.mix" in tags(g2.material_slots[0].material), tags(g2.material_slots[0].material)
free(g2, "snow")

# A Shift+D copy of a renamed pool: its Free lets go of the record only.
floor, fm = floor_material("Floor", (0, -6, -0.5))
pool = plane("Pool", 1.0, (0, -6, 0))
ps = caustics(pool, floor)
bake(pool, "caustics")
folder = ps.bake_folder
pool.name = "Pool2"
copy = in_blender.duplicate(pool)
free(copy, "caustics")
assert ps.is_baked and os.path.isfile(frame_path(folder, "caustics", 1, "exr"))
assert "caustics.multiply" in tags(fm) and not copy.hydrobake_caustics.is_baked
free(pool, "caustics")  # now the only holder: the files go
assert not os.path.exists(folder) and tags(fm) == []

# A newcomer given a renamed pool's name: its Free touches nothing of the pool's; a resume
# of the renamed pool keeps its old folder, and the newcomer cannot bake into it.
pool = plane("Pool", 1.0, (0, -6, 0))
ps = caustics(pool, floor)
bake(pool, "caustics")
folder = ps.bake_folder
pool.name = "Big"
ps.frame_end = 3
bake(pool, "caustics", resume=True)
assert ps.bake_folder == folder
newcomer = plane("Pool", 1.0, (2.5, -6, 0))
caustics(newcomer, floor)
free(newcomer, "caustics")
assert ps.is_baked and os.path.isfile(frame_path(folder, "caustics", 3, "exr"))
try:
    bake(newcomer, "caustics")
    raise AssertionError("the newcomer baked into Big's folder")
except RuntimeError as exc:
    assert "Big records a caustics bake" in str(exc), str(exc)
free(pool, "caustics")

# The ground changed between two bakes: the old floor is unwired at once.
fa, ma = floor_material("FloorA", (0, -12, -0.5))
fb, mb = floor_material("FloorB", (0, -12, -0.8))
p3 = plane("Pool3", 1.0, (0, -12, 0))
s3 = caustics(p3, fa)
bake(p3, "caustics")
s3.ground_object = fb
bake(p3, "caustics")
assert tags(ma) == [] and "caustics.multiply" in tags(mb), (tags(ma), tags(mb))
free(p3, "caustics")
assert tags(mb) == []


def freed_original(name, y):
    """A glass baked, Shift+D copied (the copy keeps the record) and freed: the copy is the
    last to record its bake. Returns the glass, its bake's folder and the copy."""
    glass = plane(name, loc=(0, y, 1))
    rain(glass)
    bake(glass, "rain")
    folder = bpy.path.abspath(glass.hydrobake_rain.bake_folder)
    copy = in_blender.duplicate(glass)
    free(glass, "rain")
    assert os.path.isdir(folder), "the copy's record keeps the files"
    return glass, folder, copy


# The copy re-baked after its original was deleted: its own bake replaces the original's,
# whose folder goes at the next save, as a renamed object's old bake does (once listed as a
# known monkey finding).
pane, old, copy = freed_original("Pane", -18)
bpy.data.objects.remove(pane)
bake(copy, "rain")
new = bpy.path.abspath(copy.hydrobake_rain.bake_folder)
assert new != old
bpy.ops.wm.save_mainfile()
assert not os.path.exists(old), os.listdir(old)
assert os.path.isfile(os.path.join(new, "manifest.json"))
free(copy, "rain")

# The copy re-baked, then its original baked again in its old folder and deleted while
# baked: that bake is the deleted object's now (Undo brings it back), not the one the copy
# replaced, and the save keeps its files (monkey --relations 27).
pane, old, copy = freed_original("Pane2", -21)
bake(copy, "rain")
bake(pane, "rain")
assert bpy.path.abspath(pane.hydrobake_rain.bake_folder) == old
bpy.data.objects.remove(pane)
bpy.ops.wm.save_mainfile()
assert os.path.isfile(os.path.join(old, "manifest.json")), "the deleted object's bake was freed"
free(copy, "rain")

print("SHARED RECORDS OK")
