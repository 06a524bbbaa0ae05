"""A material whose nodes were off, baked in place by one object and then shared: the other
object's bake copies it with its nodes on. The copy records that they were off, so that it
looks like the artist's material when it is left clean, and when it becomes the material
again (the original left the file at a save: every flag + --relations 120, where it kept
its nodes on after Free All Bakes)."""
import bpy

import in_blender

in_blender.enable()
in_blender.empty_file("nodes_off.blend")


def plain_material(name):
    mat = bpy.data.materials.new(name)
    mat.use_nodes = False
    return mat


def glass(name, mat, x):
    obj = in_blender.uv_plane(name)
    obj.location.x = x
    obj.data.materials.append(mat)
    in_blender.rain_once(obj)
    return obj


def bake(name):
    assert bpy.ops.hydrobake.bake(effect="rain", object_name=name) == {"FINISHED"}


def free(name):
    assert bpy.ops.hydrobake.free_bake(effect="rain", object_name=name) == {"FINISHED"}


def shows(name):
    return bpy.data.objects[name].material_slots[0].material


def nodes_off(name):
    mat = shows(name)
    assert mat is not None and not mat.use_nodes, (name, mat and mat.name)
    assert not [k for k in mat.keys() if k.startswith("hydrobake")], (mat.name, mat.keys())


# A bakes in place; B is given the material and baked (a copy), then A's slot is given
# another material and a save drops the first: B's Free makes the copy the material again.
mat = plain_material("Plain")
glass("A", mat, 0.0)
bake("A")
assert mat.use_nodes and shows("A") == mat
glass("B", mat, 3.0)
bake("B")
assert shows("B") != mat and shows("B")["hydrobake_copy_of"] == "Plain"
bpy.data.objects["A"].material_slots[0].material = plain_material("Other")
in_blender.reopen()
assert bpy.data.materials.get("Plain") is None or bpy.data.materials["Plain"] == shows("B")
free("B")
assert shows("B").name == "Plain", shows("B").name
nodes_off("B")
free("A")
nodes_off("A")

# C bakes in place; D is given the material and C bakes again: a copy for C, as D shows the
# material. D's slot is given another material, a save drops the first, and C's Free makes
# the copy the material again.
mat = plain_material("Plain2")
glass("C", mat, 10.0)
bake("C")
glass("D", mat, 13.0)
bake("C")
assert shows("C") != mat and shows("C")["hydrobake_copy_of"] == "Plain2"
bpy.data.objects["D"].material_slots[0].material = plain_material("Other2")
in_blender.reopen()
free("C")
assert shows("C").name == "Plain2", shows("C").name
nodes_off("C")

# A copy left clean while the material holds the other object's bake shows the artist's
# material, nodes off; the material is put back once that bake is freed.
mat = plain_material("Plain3")
glass("E", mat, 20.0)
bake("E")
glass("F", mat, 23.0)
bake("F")
free("F")
assert shows("F") != mat and "hydrobake_copy_of" in shows("F")
assert not shows("F").use_nodes, "the clean copy shows nodes the artist's material has off"
free("E")
assert shows("E") == mat and shows("F") == mat, (shows("E").name, shows("F").name)
nodes_off("E")
assert not [m.name for m in bpy.data.materials if "hydrobake_copy_of" in m]
print("SHARED NODES OFF OK")
