"""File > External Data > Pack Resources, then a re-bake (no Free first) of each effect: its
images and volume read the new bake, not the copy packed from the old one (monkey --external
4 and 7, where the fluid's volume went on showing the packed first frame of the bake before;
an image another material shows outlives the bake's wiring and is taken up by name the same
way). One-frame bakes, since Blender packs no sequences."""
import os

import bpy

import in_blender

in_blender.enable()
tmp = in_blender.empty_file("packed.blend")
rain = in_blender.uv_plane("Glass").hydrobake_rain
rain.enabled, rain.use_scene_range, rain.frame_start, rain.frame_end = True, False, 1, 1
rain.rain.cell_size, rain.rain.rain_rate = 0.05, 4000.0  # drops in the one frame
ground = in_blender.uv_plane("Ground")
ground.location.z = -0.4
ground.data.materials.append(bpy.data.materials.new("GroundMat"))
ground.data.materials[0].use_nodes = True
caustics = in_blender.new_plane("Water").hydrobake_caustics
caustics.enabled, caustics.ground_object = True, ground
caustics.use_scene_range, caustics.frame_start, caustics.frame_end = False, 1, 1
caustics.water.width, caustics.map_resolution = 16, 32
snowy = in_blender.uv_plane("Snowy")
snowy.location.x = 3.0
in_blender.snow(snowy, (1, 1), 40.0, 16)
domain, _fill, fluid = in_blender.dam_break((24, 12, 12), textures=2, frames=(1, 1))
domain.location.y = fill_y = 3.0
_fill.location.y += fill_y
bakes = {"Glass": "rain", "Water": "caustics", "Snowy": "snow", "Domain": "fluid"}
for name, effect in bakes.items():
    assert bpy.ops.hydrobake.bake(effect=effect, object_name=name) == {"FINISHED"}, name
bpy.ops.wm.save_mainfile()


def blocks():
    return [b for b in (*bpy.data.images, *bpy.data.volumes)
            if b.name.startswith("HBK") and b.users and b.filepath]


assert bpy.ops.file.pack_all() == {"FINISHED"}
old = {b.name: b.packed_file.data for b in blocks() if b.packed_file is not None}
packed = sorted(old)
kinds = {type(b).__name__ for b in blocks() if b.name in old}
assert kinds == {"Image", "Volume"}, (kinds, packed)
# The artist shows the glass's drops in a material of their own too: the image outlives the
# bake's wiring, so the re-bake takes it up again by name.
board = in_blender.new_plane("Board")
board.location.x = -3.0
board.data.materials.append(bpy.data.materials.new("BoardMat"))
board.data.materials[0].use_nodes = True
shown = board.data.materials[0].node_tree.nodes.new("ShaderNodeTexImage")
shown.image = bpy.data.images["HBK_Glass_rain_normal"]
# A change each bake shows, then Bake again over the bake: its files are new.
rain.rain.drop_mass *= 2.0
# Another file name: Blender's reload re-packs a same-named one from its path.
rain.frame_start = rain.frame_end = 2
caustics.water.width, caustics.map_resolution = 20, 48
snowy.hydrobake_snow.snow.texture_width = snowy.hydrobake_snow.snow.texture_height = 24
fluid.fluid.substeps = 2
for name, effect in bakes.items():
    assert bpy.ops.hydrobake.bake(effect=effect, object_name=name) == {"FINISHED"}, name
stale, same = [], []
for b in blocks():
    path = bpy.path.abspath(b.filepath)
    assert os.path.isfile(path), (b.name, b.filepath)
    with open(path, "rb") as f:
        data = f.read()
    if b.packed_file is not None and data != b.packed_file.data:
        stale.append(b.name)
    if old.get(b.name) == data:
        same.append(b.name)
assert not stale, f"still showing the packed copy of the old bake: {stale} (packed: {packed})"
for b in blocks():
    if b.name in old:
        assert b.packed_file is None, b.name  # it reads its file again
assert not same, f"the re-bake wrote the same {same}: the test shows nothing there"
print("packed:", packed)
print("PACKED REBAKE OK")
