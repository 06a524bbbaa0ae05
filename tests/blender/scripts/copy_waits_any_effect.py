"""A clean copy a pool's bake made of its shared water material, whose other user (a ground)
shows another pool's floor in it: after the pool's Free the copy waits for that floor to go,
whichever effect's Free comes first. A snow object's Free put the shared material back, and
the other pool's caustic map on this pool's water (monkey --renames 2)."""
import bpy

import in_blender

in_blender.enable()

in_blender.empty_file("waits.blend")


def run(op, obj, effect):
    assert getattr(bpy.ops.hydrobake, op)(effect=effect, object_name=obj.name) == {"FINISHED"}


def slot(obj):
    return obj.material_slots[0].material.name


shared = in_blender.node_material("Shared")
ground = in_blender.new_plane("Ground")
ground.scale, ground.location = (3.0, 3.0, 1.0), (0.0, 0.0, -0.5)
ground.data.materials.append(shared)
floor = in_blender.new_plane("Floor")  # pool A's own ground
floor.scale, floor.location = (3.0, 3.0, 1.0), (10.0, 0.0, -0.5)
floor.data.materials.append(in_blender.node_material("Tiles"))
pools = []
for name, x, under in (("PoolA", 10.0, floor), ("PoolB", 0.0, ground)):
    pool = in_blender.new_plane(name)
    pool.location.x = x
    pool.data.materials.append(shared if name == "PoolA" else in_blender.node_material("W"))
    s = pool.hydrobake_caustics
    s.enabled, s.ground_object = True, under
    s.use_scene_range, s.frame_start, s.frame_end = False, 1, 1
    s.water.width, s.map_resolution = 16, 32
    pools.append(pool)
pool_a, pool_b = pools
rock = in_blender.new_box("Rock", (0.5, 0.5, 0.5), (20.0, 0.0, 0.0))
rock.data.materials.append(in_blender.node_material("Stone"))
sn = in_blender.snow(rock, (1, 1), 100)
sn.snow.contact_mode = "BOX"

run("bake", pool_a, "caustics")  # Shared is the ground's too: the water goes into a copy
assert slot(pool_a) == "Shared (PoolA)", slot(pool_a)
run("bake", pool_b, "caustics")  # pool B's floor nodes go into Shared (the ground's)
run("free_bake", pool_a, "caustics")
assert slot(pool_a) == "Shared (PoolA)", slot(pool_a)  # waits: Shared shows B's floor
run("bake", rock, "snow")
run("free_bake", rock, "snow")
assert slot(pool_a) == "Shared (PoolA)", slot(pool_a)  # still waits
run("free_bake", pool_b, "caustics")
assert slot(pool_a) == "Shared", slot(pool_a)  # B's floor gone: the shared one back
assert "Shared (PoolA)" not in bpy.data.materials
print("COPY WAITS OK")
