"""A shared material renamed by the artist while a bake's copy stands for it (the copy records
the name it had): Free puts the renamed material back. Before, Free took it for gone and left
the copy in its place under the old name, cut off from the artist's; or, with a new material
given the old name, put that one in the slot."""
import bpy

import in_blender

in_blender.enable()
in_blender.empty_file("renamed.blend")


def glasses(mat_name, names, x):
    """Planes sharing a new material ``mat_name``, each with a one-frame rain."""
    mat = in_blender.node_material(mat_name)
    out = []
    for k, name in enumerate(names):
        obj = in_blender.uv_plane(name)
        obj.location.x = x + 3.0 * k
        obj.data.materials.append(mat)
        in_blender.rain_once(obj)
        out.append(obj)
    return mat, out


def bake(obj):
    assert bpy.ops.hydrobake.bake(effect="rain", object_name=obj.name) == {"FINISHED"}


def free(name):
    assert bpy.ops.hydrobake.free_bake(effect="rain", object_name=name) == {"FINISHED"}


def shows(name):
    return bpy.data.objects[name].material_slots[0].material


def no_copies():
    return [m.name for m in bpy.data.materials if "hydrobake_copy_of" in m]


# Renamed, then Free.
mat, (a, b) = glasses("GlassMat", ("A", "B"), 0.0)
bake(a)
assert shows("A") != mat and shows("A")["hydrobake_copy_of"] == "GlassMat"
mat.name = "Windshield"
free("A")
assert shows("A") == mat and shows("B") == mat, (shows("A").name, shows("B").name)
assert not no_copies(), no_copies()
assert bpy.data.materials.get("GlassMat") is None
assert "hydrobake_shared_as" not in mat, "the mark outlived the bake"

# Renamed, saved and opened, a new material given the old name, then Free: the renamed one
# goes back, not the new one.
mat, (c, d) = glasses("SideMat", ("C", "D"), 10.0)
bake(c)
mat.name = "Side Window"
in_blender.reopen()
other = in_blender.node_material("SideMat")
free("C")
mat = bpy.data.materials["Side Window"]
assert shows("C") == mat, shows("C").name
assert other.users == 0 and not no_copies(), no_copies()

# Duplicated by the artist (its custom properties with it, as the material's New button
# does), then the original renamed: the original goes back, and the duplicate keeps no mark.
mat, (e, f) = glasses("RearMat", ("E", "F"), 20.0)
bake(e)
dup = mat.copy()
assert dup.name == "RearMat.001"
mat.name = "Rear Window"
free("E")
assert shows("E") == mat, shows("E").name
assert "hydrobake_shared_as" not in dup and "hydrobake_shared_as" not in mat

# Renamed between two objects' bakes: the second copy records the new name; each Free puts
# the renamed one back.
mat, (g, h, k) = glasses("RoofMat", ("G", "H", "K"), 30.0)
bake(g)
mat.name = "Roof"
bake(h)
assert shows("H")["hydrobake_copy_of"] == "Roof" == shows("G")["hydrobake_copy_of"]
assert (shows("G").name, shows("H").name) == ("Roof (G)", "Roof (H)")  # (named anew too)
mat.name = "Sunroof"
free("G")
free("H")
assert [shows(n) for n in "GHK"] == [mat] * 3, [shows(n).name for n in "GHK"]
assert not no_copies(), no_copies()
assert "hydrobake_shared_as" not in mat

# The baked object deleted: its copy goes with it at a save (the first keeps it for the
# deleted object's mesh, the second finds it used by nothing). No Free will come, so the
# mark no copy records goes when the file opens (materials.tidy_on_load).
glasses("DeadMat", ("D1", "D2"), 40.0)
bake(bpy.data.objects["D1"])
bpy.data.objects.remove(bpy.data.objects["D1"])
in_blender.reopen()
assert "hydrobake_shared_as" in bpy.data.materials["DeadMat"]  # (its copy is still here)
in_blender.reopen()
assert bpy.data.materials.get("DeadMat (D1)") is None, "the copy was meant to go"
assert "hydrobake_shared_as" not in bpy.data.materials["DeadMat"], "a dead mark stayed"
print("RENAMED SHARED OK")
