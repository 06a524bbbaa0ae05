"""Two pools over one floor, sharing one water material: each bake multiplies its own caustic
map into the floor (a chain of multiplies, one per pool, each clipped to its pool), each pool
gets its own copy of the water material, a re-bake keeps the chain as it is, and freeing one
pool takes out only its own nodes."""
import os

import bpy

import in_blender

in_blender.enable()
from hydrobake.blender.bridge import materials  # noqa: E402

in_blender.empty_file("pools.blend")
floor = in_blender.new_plane("Floor")
floor.scale, floor.location = (4.0, 2.0, 1.0), (0.0, 0.0, -0.5)
fmat = in_blender.node_material("Tiles")
floor.data.materials.append(fmat)
ftree = fmat.node_tree
bsdf = materials.principled(ftree)
tiles = ftree.nodes.new("ShaderNodeTexChecker")
ftree.links.new(tiles.outputs["Color"], bsdf.inputs["Base Color"])
water = in_blender.node_material("Water")
pools = []
for name, x in (("Left", -1.5), ("Right", 1.5)):
    pool = in_blender.new_plane(name)
    pool.location = (x, 0.0, 0.0)
    pool.data.materials.append(water)
    s = pool.hydrobake_caustics
    s.enabled, s.ground_object = True, floor
    s.use_scene_range, s.frame_start, s.frame_end = False, 1, 2
    s.water.width, s.map_resolution = 16, 32
    pools.append(pool)
left, right = pools


def chain():
    """The owners of the multiplies feeding the floor's base colour, nearest first, and what
    feeds the last one."""
    owners, socket = [], bsdf.inputs["Base Color"]
    while socket.is_linked and socket.links[0].from_node.get("hydrobake") == \
            "caustics.multiply":
        node = socket.links[0].from_node
        tex = node.inputs["Color2"].links[0].from_node
        assert tex.image.name == f"HBK_{node['hydrobake_owner']}_caustics", tex.image.name
        assert node.inputs["Fac"].links[0].from_node.extension == "CLIP"
        owners.append(node["hydrobake_owner"])
        assert len(owners) <= 2, owners  # a loop in the chain
        socket = node.inputs["Color1"]
    return owners, socket.links[0].from_node.name if socket.is_linked else None


def bake(pool):
    assert bpy.ops.hydrobake.bake(effect="caustics", object_name=pool.name) == {"FINISHED"}


def free(pool):
    assert bpy.ops.hydrobake.free_bake(effect="caustics", object_name=pool.name) == \
        {"FINISHED"}


bake(left)
assert chain() == (["Left"], tiles.name), chain()
bake(right)
assert chain() == (["Right", "Left"], tiles.name), chain()
# Each pool's normals in a material of its own: the first to bake took a copy of the shared
# one, which the second then had to itself.
assert left.active_material.name == "Water (Left)" and right.active_material == water
for pool in pools:
    tex = materials.tagged(pool.active_material.node_tree, "caustics.surface")
    assert tex.image.name == f"HBK_{pool.name}_surface", tex.image.name
bake(left)  # a re-bake: the same chain, no loop
assert chain() == (["Right", "Left"], tiles.name), chain()
assert len([n for n in ftree.nodes if n.get("hydrobake") == "caustics.multiply"]) == 2
free(left)
assert chain() == (["Right"], tiles.name), chain()
assert not any(n.get("hydrobake_owner") == "Left" for n in ftree.nodes)
# Left keeps its clean copy while the shared material holds Right's wiring.
assert not any(n.get("hydrobake") for n in left.active_material.node_tree.nodes)
free(right)
assert chain() == ([], tiles.name), chain()
assert not any(n.get("hydrobake") for n in ftree.nodes)
assert not any(n.get("hydrobake") for n in water.node_tree.nodes)

# Renamed after its bake: a new object given the old name is refused until the renamed pool
# re-bakes, which frees its bake under the old name (complete, and no other object's).
bake(left)
folder = left.hydrobake_caustics.bake_folder
left.name = "Pond"
newcomer = in_blender.new_plane("Left")
newcomer.location = (-1.5, 0.0, 0.0)
ns = newcomer.hydrobake_caustics
ns.enabled, ns.use_scene_range, ns.frame_start, ns.frame_end = True, False, 1, 1
ns.water.width, ns.map_resolution = 16, 32
try:
    bake(newcomer)
    raise AssertionError("the newcomer took Pond's name")
except RuntimeError as exc:
    assert "Pond records a caustics bake made under this name" in str(exc), str(exc)
bake(left)
assert os.path.isdir(folder)  # the saved file still records it
bpy.ops.wm.save_mainfile()
assert not os.path.exists(folder) and os.path.isdir(left.hydrobake_caustics.bake_folder)
bake(newcomer)
assert os.path.realpath(ns.bake_folder) == os.path.realpath(folder)
assert os.path.isdir(left.hydrobake_caustics.bake_folder)
print("CAUSTICS TWO POOLS OK")
