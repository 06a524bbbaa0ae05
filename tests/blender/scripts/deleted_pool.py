"""A baked pool deleted without Free Bake: its caustics leave the floor's material (which
another object shows) with the pool's projector, and the floor is as before the bake; its
files stay, as any deleted object's. Deleted as the UI deletes (an update follows) and by a
script that saves right after (no update between)."""
import os

import bpy

import in_blender

in_blender.enable()
from hydrobake.blender.bridge import materials  # noqa: E402

tmp = in_blender.empty_file("deleted_pool.blend")


def pool(name, ground):
    water = in_blender.uv_plane(name)
    s = water.hydrobake_caustics
    s.enabled, s.ground_object, s.projector = True, ground, True
    s.use_scene_range, s.frame_start, s.frame_end = False, 1, 2
    s.water.width, s.map_resolution = 16, 32
    return water


def floor_nodes():
    return sorted(str(n.get(materials.TAG)) for n in floor.node_tree.nodes
                  if n.get(materials.TAG))


ground = in_blender.uv_plane("Ground")
ground.location.z = -0.5
floor = in_blender.node_material("Tiles")
ground.data.materials.append(floor)
before = sorted(n.name for n in floor.node_tree.nodes), len(floor.node_tree.links)

water = pool("Water", ground)
assert bpy.ops.hydrobake.bake(effect="caustics", object_name="Water") == {"FINISHED"}
folder = bpy.path.abspath(water.hydrobake_caustics.bake_folder)
assert floor_nodes() and "HBK_Water_projector" in bpy.data.objects
bpy.data.objects.remove(water)
bpy.context.view_layer.update()  # what the UI does after a delete
assert not floor_nodes(), f"the deleted pool's caustics stayed on the floor: {floor_nodes()}"
assert (sorted(n.name for n in floor.node_tree.nodes), len(floor.node_tree.links)) == before
assert "HBK_Water_projector" not in bpy.data.objects
assert "HBK_Water_caustics" not in bpy.data.images
assert os.path.isfile(os.path.join(folder, "manifest.json")), "the deleted pool's files went"

# Two pools over the floor, one deleted by a script that saves at once: the other's stay.
a, b = pool("Pool A", ground), pool("Pool B", ground)
for name in ("Pool A", "Pool B"):
    assert bpy.ops.hydrobake.bake(effect="caustics", object_name=name) == {"FINISHED"}
owners = {n.get(materials.OWNER) for n in floor.node_tree.nodes if n.get(materials.TAG)}
assert owners == {"Pool A", "Pool B"}, owners
bpy.data.objects.remove(a)
bpy.ops.wm.save_mainfile()
owners = {n.get(materials.OWNER) for n in floor.node_tree.nodes if n.get(materials.TAG)}
assert owners == {"Pool B"}, f"after the save the floor holds {owners}"
bpy.ops.wm.open_mainfile(filepath=os.path.join(tmp, "deleted_pool.blend"))
floor = bpy.data.materials["Tiles"]
owners = {n.get(materials.OWNER) for n in floor.node_tree.nodes if n.get(materials.TAG)}
assert owners == {"Pool B"}, f"the saved floor holds {owners}"
assert bpy.ops.hydrobake.free_bake(effect="caustics", object_name="Pool B") == {"FINISHED"}
assert not floor_nodes()

# The ground deleted and the file saved and opened (its floor material, unused, goes),
# then the pool (surface displaced, a projector): its projector and grid Empty are all it
# leaves, and they go with it; the water's wiring goes with Remove Deleted Objects' Bakes.
ground = bpy.data.objects["Ground"]
c = pool("Pool C", ground)
c.hydrobake_caustics.displace_surface = True
assert bpy.ops.hydrobake.bake(effect="caustics", object_name="Pool C") == {"FINISHED"}
helpers = ("HBK_Pool C_projector", "HBK_Pool C_grid")
assert all(name in bpy.data.objects for name in helpers)
bpy.data.objects.remove(ground)
for _ in range(2):  # the mesh goes at the first save, its material, then unused, at the next
    bpy.ops.wm.save_mainfile()
    bpy.ops.wm.open_mainfile(filepath=os.path.join(tmp, "deleted_pool.blend"))
assert "Tiles" not in bpy.data.materials
bpy.data.objects.remove(bpy.data.objects["Pool C"])
bpy.context.view_layer.update()


def left_of(pool):
    return [o.name for o in bpy.data.objects if o.name.startswith(f"HBK_{pool}_")] + \
        [b.name for blocks in (bpy.data.images, bpy.data.lights, bpy.data.textures)
         for b in blocks if b.name.startswith(f"HBK_{pool}_")]


assert sorted(left_of("Pool C")) == ["HBK_Pool C_height", "HBK_Pool C_height",
                                     "HBK_Pool C_surface"], left_of("Pool C")
assert bpy.ops.hydrobake.remove_deleted_bakes(effect="caustics") == {"FINISHED"}
assert not left_of("Pool C"), left_of("Pool C")
print("DELETED POOL OK")