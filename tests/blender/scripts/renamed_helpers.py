"""Helper objects a bake adds, renamed by the artist: a pool's projector (object and light)
and grid Empty, a snow object's falling flakes. A re-bake updates the renamed one (before,
it added a second projector beside it, lighting the floor twice over), a reopened file still
knows it, and Free Bake and Remove Deleted Objects' Bakes take it out. So with the modifiers
a bake adds (a pool's Subdivision and Displace, snow's BOX mode), and a pool's height texture."""
import os

import bpy

import in_blender

in_blender.enable()

in_blender.empty_file("helpers.blend")


def bake(obj, effect):
    assert bpy.ops.hydrobake.bake(effect=effect, object_name=obj.name) == {"FINISHED"}


def free(name, effect):
    assert bpy.ops.hydrobake.free_bake(effect=effect, object_name=name) == {"FINISHED"}


def of_type(kind):
    return sorted(o.name for o in bpy.data.objects if o.type == kind)


floor = in_blender.new_plane("Floor")
floor.scale, floor.location = (3.0, 3.0, 1.0), (0.0, 0.0, -0.5)
floor.data.materials.append(in_blender.node_material("Tiles"))
pool = in_blender.new_plane("Pool")
pool.scale = (1.5, 1.5, 1.0)
s = pool.hydrobake_caustics
s.enabled, s.ground_object = True, floor
s.use_scene_range, s.frame_start, s.frame_end = False, 1, 2
s.water.width, s.map_resolution = 32, 64
s.displace_surface, s.projector = True, True
bake(pool, "caustics")
assert of_type("LIGHT") == ["HBK_Pool_projector"] and of_type("EMPTY") == ["HBK_Pool_grid"]

# Renamed (object and light), then re-baked with another power: the same projector, updated.
sun = bpy.data.objects["HBK_Pool_projector"]
sun.name, sun.data.name = "PoolSun", "PoolSunLight"
bpy.data.objects["HBK_Pool_grid"].name = "PoolGrid"
s.projector_power = 123.0
bake(pool, "caustics")
assert of_type("LIGHT") == ["PoolSun"], of_type("LIGHT")
assert of_type("EMPTY") == ["PoolGrid"], of_type("EMPTY")
assert sun.data.name == "PoolSunLight" and abs(sun.data.energy - 123.0) < 1e-4
assert pool.modifiers["HBK Displace"].texture_coords_object == bpy.data.objects["PoolGrid"]
assert [light.name for light in bpy.data.lights if light.users] == ["PoolSunLight"]

# Its Subdivision and Displace renamed, and the height texture: the same pair re-baked, not a
# second one subdividing the water again and displacing it twice.
pool.modifiers["HBK Subdivision"].name = "Fine"
pool.modifiers["HBK Displace"].name = "Waves"
pool.modifiers["Waves"].texture.name = "Heights"
bake(pool, "caustics")
assert [(m.name, m.type) for m in pool.modifiers] == [("Fine", "SUBSURF"),
                                                      ("Waves", "DISPLACE")], pool.modifiers[:]
assert pool.modifiers["Waves"].texture.name == "Heights"

# A reopened file still knows them.
in_blender.reopen()
pool, s = bpy.data.objects["Pool"], bpy.data.objects["Pool"].hydrobake_caustics
bake(pool, "caustics")
assert of_type("LIGHT") == ["PoolSun"] and of_type("EMPTY") == ["PoolGrid"]

# The grid Empty deleted as well: the renamed Displace is known by its texture's record.
bpy.data.objects.remove(bpy.data.objects["PoolGrid"])
bake(pool, "caustics")
assert [(m.name, m.type) for m in pool.modifiers] == [("Fine", "SUBSURF"),
                                                      ("Waves", "DISPLACE")], pool.modifiers[:]
assert of_type("EMPTY") == ["HBK_Pool_grid"], of_type("EMPTY")

# The projector turned off: the renamed one goes.
s.projector = False
bake(pool, "caustics")
assert of_type("LIGHT") == [] and "PoolSunLight" not in bpy.data.lights, of_type("LIGHT")
s.projector = True
bake(pool, "caustics")
bpy.data.objects["HBK_Pool_projector"].name = "PoolSun"

# Free Bake takes the renamed ones out, light, modifiers, texture and all.
free("Pool", "caustics")
assert not pool.modifiers and "Heights" not in bpy.data.textures, pool.modifiers[:]
assert of_type("LIGHT") == [] and of_type("EMPTY") == [], (of_type("LIGHT"), of_type("EMPTY"))
assert not any(light.name.startswith(("HBK_", "PoolSun")) for light in bpy.data.lights)

# Deleted while baked, its helpers renamed: Remove Deleted Objects' Bakes takes them out.
bake(pool, "caustics")
bpy.data.objects["HBK_Pool_projector"].name = "PoolSun"
bpy.data.objects["HBK_Pool_grid"].name = "PoolGrid"
bpy.data.objects.remove(pool)
assert bpy.ops.hydrobake.remove_deleted_bakes() == {"FINISHED"}
assert of_type("LIGHT") == [] and of_type("EMPTY") == [], (of_type("LIGHT"), of_type("EMPTY"))

# Snow's falling flakes, renamed: one flakes object, showing the re-bake's files.
rock = in_blender.new_box("Rock", (0.5, 0.5, 0.5), (5.0, 0.0, 0.0))
rock.data.materials.append(in_blender.node_material("Stone"))
sn = in_blender.snow(rock, (1, 2), 200)
sn.write_flakes, sn.snow.contact_mode = True, "BOX"
bake(rock, "snow")
flakes = bpy.data.objects["HBK_Rock_flakes"]
flakes.name = "MyFlakes"
rock.modifiers["HBK Snow Box"].name = "Box"  # (BOX mode's)
sn.cache_dir = os.path.join(in_blender.args()[0], "elsewhere", "")  # another folder
bake(rock, "snow")
shown = [o for o in bpy.data.objects if o.get("hydrobake_sequence")]
assert [o.name for o in shown] == ["MyFlakes"], [o.name for o in shown]
assert "elsewhere" in shown[0]["hydrobake_sequence"], shown[0]["hydrobake_sequence"]
assert [m.type for m in rock.modifiers] == ["NODES"], rock.modifiers[:]
free("Rock", "snow")
assert not rock.modifiers, rock.modifiers[:]
assert not [o.name for o in bpy.data.objects if o.type == "MESH" and o.name != "Floor"
            and o.name != "Rock"]

bake(rock, "snow")
bpy.data.objects["HBK_Rock_flakes"].name = "MyFlakes"
bpy.data.objects.remove(rock)
assert bpy.ops.hydrobake.remove_deleted_bakes() == {"FINISHED"}
assert "MyFlakes" not in bpy.data.objects, of_type("MESH")
print("RENAMED HELPERS OK")
