"""A bake's copy on an object's own slot of a shared mesh records that the slot's Link was
the mesh's, for its Free to switch back. A copy of that copy, made by another object's bake,
keeps the record only where it holds there too: on a Shift+D copy of the object, whose mesh
shows the shared material in that slot. On a slot the artist gave the copy (Link: Object,
another material in the mesh's slot), Free puts the shared material in the slot as it is;
before, it switched the Link and the slot showed the mesh's other material (every flag +
--scene --external 950, where the mesh's slot was empty). In the mesh's slot of an object
it never holds."""
import bpy

import in_blender

in_blender.enable()
in_blender.empty_file("given_copy_link.blend")

shared = in_blender.node_material("Shared")
other = in_blender.node_material("Other")

# A and its Alt+D copy A2 share a mesh whose slot shows Shared: A's bake gives A's own slot
# its copy, and records the Link it switched.
a = in_blender.uv_plane("A")
a.data.materials.append(shared)
a2 = in_blender.duplicate(a, linked=True)
a2.location.x = 3.0
in_blender.rain_once(a)
assert bpy.ops.hydrobake.bake(effect="rain", object_name="A") == {"FINISHED"}
a_copy = a.material_slots[0].material
assert a.material_slots[0].link == "OBJECT" and a_copy.name == "Shared (A)"
assert a_copy["hydrobake_link_was"] == "DATA"

# B: its mesh's slot shows Other; the artist links the slot to the object and gives it A's
# copy (as Link Materials or the slot's menu would).
b = in_blender.uv_plane("B")
b.location.x = 6.0
b.data.materials.append(other)
b.material_slots[0].link = "OBJECT"
b.material_slots[0].material = a_copy

# C: a Shift+D copy of A, made while A is baked: its own mesh shows Shared in the slot, its
# own slot A's copy.
c = in_blender.duplicate(a)
c.name = "C"
assert c.data != a.data and c.data.materials[0] == shared
assert c.material_slots[0].link == "OBJECT" and c.material_slots[0].material == a_copy

for o in (b, c):
    in_blender.rain_once(o)
    assert bpy.ops.hydrobake.bake(effect="rain", object_name=o.name) == {"FINISHED"}
    mine = o.material_slots[0].material
    assert mine.name == f"Shared ({o.name})" and mine["hydrobake_copy_of"] == "Shared"
    assert bpy.ops.hydrobake.free_bake(effect="rain", object_name=o.name) == {"FINISHED"}

# B shows what its copy stood for, on its own slot; C's Link is back to its mesh's, which
# shows Shared, as before A's bake.
sb, sc = b.material_slots[0], c.material_slots[0]
assert (sb.link, sb.material) == ("OBJECT", shared), (sb.link, sb.material)
assert (sc.link, sc.material) == ("DATA", shared), (sc.link, sc.material)
assert b.data.materials[0] == other

# A's Free gives A and A2 the mesh's slot back, and its copy goes.
assert bpy.ops.hydrobake.free_bake(effect="rain", object_name="A") == {"FINISHED"}
for o in (a, a2):
    sl = o.material_slots[0]
    assert (sl.link, sl.material) == ("DATA", shared), (o.name, sl.link, sl.material)
left = [m.name for m in bpy.data.materials if "hydrobake_copy_of" in m]
assert not left, left

# The same holds after a reopen (the record is a custom property, saved with the copy).
in_blender.reopen()
sb = bpy.data.objects["B"].material_slots[0]
assert (sb.link, sb.material.name) == ("OBJECT", "Shared")

# The record holds on an object's own slot only. E (one object, Link: Data) shows F's copy
# in its mesh's slot; F's mesh shows another material since, and a save drops Shared2, which
# nothing uses. E's copy of F's copy, in the mesh's slot, has no record: its Free makes it
# Shared2 again. Before, it kept the record, which stopped that, and stayed a copy (every
# flag + --relations 133).
shared2 = in_blender.node_material("Shared2")
f = in_blender.uv_plane("F")
f.location.y = 3.0
f.data.materials.append(shared2)
in_blender.duplicate(f, linked=True).location.y = 6.0
in_blender.rain_once(f)
assert bpy.ops.hydrobake.bake(effect="rain", object_name="F") == {"FINISHED"}
f_copy = f.material_slots[0].material
assert f_copy.name == "Shared2 (F)" and f_copy["hydrobake_link_was"] == "DATA"
e = in_blender.uv_plane("E")
e.location.y = 9.0
e.data.materials.append(f_copy)
in_blender.rain_once(e)
f.data.materials[0] = bpy.data.materials["Other"]
in_blender.reopen()
assert "Shared2" not in bpy.data.materials
assert bpy.ops.hydrobake.bake(effect="rain", object_name="E") == {"FINISHED"}
se = bpy.data.objects["E"].material_slots[0]
assert se.link == "DATA" and se.material.name == "Shared2 (E)", (se.link, se.material)
assert "hydrobake_link_was" not in se.material
assert bpy.ops.hydrobake.free_bake(effect="rain", object_name="E") == {"FINISHED"}
se = bpy.data.objects["E"].material_slots[0]
assert se.link == "DATA" and se.material.name == "Shared2", (se.link, se.material)
assert "hydrobake_copy_of" not in se.material
print("GIVEN COPY LINK OK")
