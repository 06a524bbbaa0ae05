"""Caustics wiring an artist's scene and giving it back: the materials a floor renders with
(every slot, a slot linked to the object), the water's own values, an old material without
nodes, a pool with no material, a ground changed, renamed or deleted after the bake, a
material swapped out of the ground, a shared one the ground shows its own copy of; Displace
Surface moving the water down as well as up, and a re-bake over its own modifiers seeing the
same grid; the floor's colour not darkened along the pool's edge (a probe render); and
settings refused by name."""
import json
import math
import os

import bmesh
import bpy
import numpy as np

import in_blender

in_blender.enable()
from hydrobake.blender.bridge import materials  # noqa: E402
from hydrobake.core import exr  # noqa: E402
from hydrobake.core.bake.cache import frame_path  # noqa: E402

tmp = in_blender.empty_file("free.blend")
scene = bpy.context.scene


def node_material(name, colour=(0.8, 0.8, 0.8, 1.0)):
    m = in_blender.node_material(name)
    materials.principled(m.node_tree).inputs["Base Color"].default_value = colour
    return m


def tags(mat):
    return sorted(n["hydrobake"] for n in mat.node_tree.nodes if n.get("hydrobake")) \
        if mat.node_tree else []


def bake(obj):
    assert bpy.ops.hydrobake.bake(effect="caustics", object_name=obj.name) == {"FINISHED"}


def free(obj):
    assert bpy.ops.hydrobake.free_bake(effect="caustics", object_name=obj.name) == \
        {"FINISHED"}


def refused(obj):
    try:
        bpy.ops.hydrobake.bake(effect="caustics", object_name=obj.name)
    except RuntimeError as exc:
        return str(exc)
    raise AssertionError("not refused")


# A floor of two materials (one per half), the left one linked to the object.
floor = in_blender.new_plane("Floor")
bm = bmesh.new()
bm.from_mesh(floor.data)
bmesh.ops.subdivide_edges(bm, edges=bm.edges[:], cuts=1, use_grid_fill=True)
bm.to_mesh(floor.data)
bm.free()
floor.scale, floor.location = (3.0, 3.0, 1.0), (0.0, 0.0, -0.5)
tiles, grout, linked = node_material("Tiles"), node_material("Grout"), node_material("Linked")
floor.data.materials.append(tiles)
floor.data.materials.append(grout)
for p in floor.data.polygons:
    p.material_index = 1 if p.center.x > 0 else 0
floor.material_slots[0].link = "OBJECT"
floor.material_slots[0].material = linked  # what the left half renders with
pool = in_blender.new_plane("Pool")
pool.scale = (1.5, 1.5, 1.0)
water = node_material("MyWater")
bsdf = materials.principled(water.node_tree)
for k, v in (("Roughness", 0.4), ("IOR", 1.45), ("Transmission", 0.3)):
    bsdf.inputs[k].default_value = v
pool.data.materials.append(water)
stone = in_blender.new_box("Stone", (0.3, 0.3, 0.2), (0.4, 0.0, 0.02))  # through the surface
stone.hide_render = True
s = pool.hydrobake_caustics
s.enabled, s.ground_object = True, floor
s.disturber_object, s.disturber_depth = stone, 0.08
s.use_scene_range, s.frame_start, s.frame_end = False, 1, 3
s.water.width, s.map_resolution, s.water.rain_rate = 32, 64, 0.0
s.displace_surface = True
bake(pool)
for mat in (linked, grout):  # both rendered halves; not the mesh's hidden slot-0 material
    assert "caustics.multiply" in tags(mat), (mat.name, tags(mat))
assert tags(tiles) == [], tags(tiles)
assert abs(bsdf.inputs["IOR"].default_value - 1.333) < 1e-6

# Displace Surface: the dent under the stone goes below the level, as baked.
scene.frame_set(3)
height = exr.read(frame_path(s.bake_folder, "height", 3, "exr"))["Y"]
dg = bpy.context.evaluated_depsgraph_get()
zs = np.array([v.co.z for v in pool.evaluated_get(dg).to_mesh().vertices])
pool.evaluated_get(dg).to_mesh_clear()
assert height.min() < -0.02 and zs.min() < 0.5 * height.min(), (height.min(), zs.min())

# A re-bake over its own Subdivision and Displace sees the same grid and the same level.
first = json.load(open(os.path.join(s.bake_folder, "manifest.json")))
h1 = exr.read(frame_path(s.bake_folder, "water", 1, "exr"))["height"]
bpy.ops.hydrobake.bake(effect="caustics", object_name="Pool")
again = json.load(open(os.path.join(s.bake_folder, "manifest.json")))
assert again["params"] == first["params"], (again["params"]["water"], first["params"]["water"])
assert np.array_equal(exr.read(frame_path(s.bake_folder, "water", 1, "exr"))["height"], h1)

# The floor's colour along the pool's edge: the map is 1 there (flat water at the edge),
# so the floor shows its own 0.8 right up to the edge, no darker line (a probe of the base
# colour rendered from above).
s.disturber_object = None  # flat water everywhere
s.displace_surface = False
free(pool)
bake(pool)
for mat in (linked, grout):
    tree = mat.node_tree
    out = next(n for n in tree.nodes if n.type == "OUTPUT_MATERIAL")
    emit = tree.nodes.new("ShaderNodeEmission")
    tree.links.new(materials.principled(tree).inputs["Base Color"].links[0].from_socket,
                   emit.inputs["Color"])
    tree.links.new(emit.outputs[0], out.inputs["Surface"])
cam = bpy.data.objects.new("Top", bpy.data.cameras.new("Top"))
scene.collection.objects.link(cam)
cam.data.type, cam.data.ortho_scale, cam.location = "ORTHO", 4.0, (0.0, 0.0, 5.0)
scene.camera = cam
pool.hide_render = True
r = scene.render
r.engine, r.resolution_x, r.resolution_y, r.resolution_percentage = "CYCLES", 128, 128, 100
r.filter_size = 0.01
scene.cycles.samples, scene.cycles.use_denoising = 1, False
scene.view_settings.view_transform = "Standard"
r.image_settings.file_format, r.image_settings.color_depth = "OPEN_EXR", "32"
r.filepath = os.path.join(tmp, "edge.exr")
scene.frame_set(1)
bpy.ops.render.render(write_still=True)
px = np.array(bpy.data.images.load(r.filepath).pixels[:]).reshape(128, 128, 4)
cmap = exr.read(frame_path(s.bake_folder, "caustics", 1, "exr"))["R"]
assert abs(cmap[:, 0].mean() - 1.0) < 0.02 and abs(cmap[:, -1].mean() - 1.0) < 0.02
row = px[64, :, 0]  # across both edges of the pool (x = -1.5 and 1.5 m: columns 16 and 112)
assert np.abs(row - 0.8).max() < 0.03, (np.round(row, 3), cmap.min(), cmap.max())
for mat in (linked, grout):
    tree = mat.node_tree
    tree.nodes.remove(next(n for n in tree.nodes if n.type == "EMISSION"))
    tree.links.new(materials.principled(tree).outputs[0],
                   next(n for n in tree.nodes if n.type == "OUTPUT_MATERIAL").inputs["Surface"])
pool.hide_render = False

# Free gives everything back: the water's values, the floor's materials, no images left.
free(pool)
assert [round(bsdf.inputs[k].default_value, 4) for k in ("Roughness", "IOR", "Transmission")] \
    == [0.4, 1.45, 0.3]
assert not any(k.startswith("hydrobake") for k in water.keys()), water.keys()
assert tags(linked) == [] and tags(grout) == [] and tags(water) == []
assert not [i.name for i in bpy.data.images if i.name.startswith("HBK_Pool")]

# A floor material without nodes and a pool without a material: as they were after Free.
old = bpy.data.materials.new("Painted")
old.diffuse_color = (1.0, 0.0, 0.0, 1.0)
plain = in_blender.new_plane("PlainFloor")
plain.location.z = -0.5
plain.data.materials.append(old)
bare = in_blender.new_plane("Bare")
bare.location.x = 8.0
plain.location.x = 8.0
b = bare.hydrobake_caustics
b.enabled, b.ground_object, b.use_scene_range, b.frame_start, b.frame_end = \
    True, plain, False, 1, 1
b.water.width, b.map_resolution = 16, 32
bake(bare)
assert old.use_nodes and "caustics.multiply" in tags(old)
assert bare.active_material.name == "HBK_Bare_water"
free(bare)
assert not old.use_nodes and tags(old) == []
assert len(bare.data.materials) == 0 and "HBK_Bare_water" not in bpy.data.materials

# The ground changed after the bake, then re-baked: Free cleans the floor it was wired into;
# a ground deleted after the bake: its material is cleaned too.
other = in_blender.new_plane("OtherFloor")
other.location = (8.0, 0.0, -0.6)
other_mat = node_material("Other")
other.data.materials.append(other_mat)
bake(bare)
b.ground_object = other
bake(bare)
free(bare)
assert tags(old) == [] and tags(other_mat) == [], (tags(old), tags(other_mat))
bake(bare)
bpy.data.objects.remove(other)
free(bare)
assert tags(other_mat) == [], tags(other_mat)
# The ground renamed, then another chosen and re-baked: the renamed one loses the pool's
# nodes at the re-bake (its old name found nothing: it went on showing the caustics), as does
# a material swapped out of the ground before a re-bake.
b.ground_object = plain
bake(bare)
plain.name = "PlainFloor renamed"
third = in_blender.new_plane("ThirdFloor")
third.location = (8.0, 0.0, -0.7)
third_mat, swapped = node_material("Third"), node_material("Swapped")
third.data.materials.append(third_mat)
b.ground_object = third
bake(bare)
assert tags(old) == [] and not old.use_nodes and "caustics.multiply" in tags(third_mat)
third.data.materials[0] = swapped
bake(bare)
assert tags(third_mat) == [] and "caustics.multiply" in tags(swapped), tags(third_mat)
free(bare)
assert tags(swapped) == []
# The ground showing its own copy of a material it shares (a snow bake's): the shared one a
# Free would put back keeps the pool's nodes at the re-bake.
twin = in_blender.new_plane("Twin")
twin.location = (16.0, 0.0, -0.7)
twin.data.materials.append(swapped)
third.data.uv_layers.new(name="UVMap")
bake(bare)
in_blender.snow(third, (1, 1), 40.0, 16)
assert bpy.ops.hydrobake.bake(effect="snow", object_name=third.name) == {"FINISHED"}
assert third.active_material != swapped
bake(bare)
assert "caustics.multiply" in tags(swapped) and "caustics.multiply" in tags(third.active_material)
assert bpy.ops.hydrobake.free_bake(effect="snow", object_name=third.name) == {"FINISHED"}
free(bare)
assert tags(swapped) == []

# Displace Surface on a water whose other half a Mirror makes: the dent under a stone in the
# mirrored half shows there (each vertex reads its own place on the grid).
half = in_blender.new_plane("Half")  # x 0..2, mirrored to -2..0
for v in half.data.vertices:
    v.co.x += 1.0
half.location = (0.0, 8.0, 0.0)
half.modifiers.new("Mirror", "MIRROR")
hfloor = in_blender.new_plane("HalfFloor")
hfloor.scale, hfloor.location = (3.0, 3.0, 1.0), (0.0, 8.0, -0.5)
pebble = in_blender.new_box("Pebble", (0.3, 0.3, 0.2), (-1.0, 8.3, 0.02))
hs = half.hydrobake_caustics
hs.enabled, hs.ground_object, hs.disturber_object, hs.disturber_depth = True, hfloor, pebble, 0.08
hs.use_scene_range, hs.frame_start, hs.frame_end = False, 1, 2
hs.water.width, hs.map_resolution, hs.displace_surface = 64, 64, True
bake(half)
scene.frame_set(2)
dg = bpy.context.evaluated_depsgraph_get()
ev = half.evaluated_get(dg).to_mesh()
low = min(ev.vertices, key=lambda v: v.co.z)
assert low.co.z < -0.01 and abs(low.co.x + 1.0) < 0.2 and abs(low.co.y - 0.3) < 0.2, \
    tuple(low.co)
half.evaluated_get(dg).to_mesh_clear()
free(half)
pebble.hide_render = True

# A disturber wholly under the water moves no surface; through it, it dents it.
b.ground_object, b.frame_end = plain, 2
rock = in_blender.new_box("Rock", (0.5, 0.5, 0.2), (8.0, 0.0, -0.2))  # z -0.3..-0.1
b.disturber_object, b.disturber_depth = rock, 0.1
for z, dented in ((-0.2, False), (0.0, True)):
    rock.location.z = z
    bake(bare)
    h = exr.read(frame_path(b.bake_folder, "water", 2, "exr"))["height"]
    assert (h.min() < -0.01) == dented, (z, h.min())
b.disturber_object = None

# Refused by name: a plane standing on its edge, a sun at the horizon, a camera under water.
edge = in_blender.new_plane("Edge")
edge.rotation_euler.x = math.radians(90.0)
edge.location.x = -8.0
edge.hydrobake_caustics.enabled = True
msg = refused(edge)
assert "must be a horizontal plane" in msg, msg
sun = bpy.data.objects.new("Lamp", bpy.data.lights.new("Lamp", "SUN"))
scene.collection.objects.link(sun)
sun.rotation_euler.x = math.radians(89.7)
b.sun_object = sun
msg = refused(bare)
assert "Sun: Lamp is 0.3 degrees above the horizon" in msg, msg
b.sun_object = None
low = bpy.data.objects.new("Low", bpy.data.cameras.new("Low"))
scene.collection.objects.link(low)
low.location = (8.0, 0.0, -0.2)
b.preview_camera, b.ground_texture = low, bpy.data.images.new("g", 8, 8)
msg = refused(bare)
assert "Bare caustics: Preview Camera: Low is at z = -0.2 m" in msg, msg
b.preview_camera = b.ground_texture = None
# The water as its own ground (a script; the panel does not offer it): its floor wiring went
# into the material its water copy was made of (monkey seed 419).
b.ground_object = bare
msg = refused(bare)
assert "Bare caustics: Ground: Bare cannot be the Ground, which takes a mesh other than the " \
    "water itself" in msg, msg
# Whatever else a script sets that the panel would not offer is refused by name, not baked
# into a traceback (a camera as the ground failed in to_mesh).
for attr, value, label, takes in (("ground_object", low, "Ground",
                                   "a mesh other than the water itself"),
                                  ("source_object", low, "Source",
                                   "a mesh, curve, surface, text or metaball"),
                                  ("disturber_object", low, "Disturber",
                                   "a mesh, curve, surface, text or metaball"),
                                  ("sun_object", floor, "Sun", "a sun lamp"),
                                  ("preview_camera", floor, "Preview Camera", "a camera")):
    b.ground_object = None
    setattr(b, attr, value)
    msg = refused(bare)
    assert f"Bare caustics: {label}: {value.name} cannot be the {label}, which takes " \
        f"{takes}" in msg, msg
    setattr(b, attr, None)
# An image whose file went missing has no pixels: named as the setting it is (a missing
# Ground Image failed with an IndexError traceback).
gone = bpy.data.images.new("gone", 8, 8)
gone.source, gone.filepath = "FILE", "/nonexistent/ground.exr"
b.ground_image = gone
msg = refused(bare)
assert "Bare caustics: Ground Image: image 'gone' has no pixels (its file " \
    "/nonexistent/ground.exr is missing?)" in msg, msg
b.ground_image = None
b.preview_camera, b.ground_texture = low, gone
low.location.z = 5.0
msg = refused(bare)
assert "Bare caustics: Ground Texture: image 'gone' has no pixels" in msg, msg
b.preview_camera = b.ground_texture = None
b.ground_object = bare
# Deleted so, the pointer to itself keeps it in the file, in no collection: baked, it would
# leave at the next save with nothing recording its folder (monkey seed 460).
homes = list(bare.users_collection)
for c in homes:
    c.objects.unlink(bare)
b.ground_object = None
msg = refused(bare)
assert "Bare: in no collection (deleted?)" in msg, msg
for c in homes:
    c.objects.link(bare)
print("CAUSTICS FREE OK")
