"""A bake's copy on an object's own slot of a shared mesh records that the slot's Link was
the mesh's, for its Free to switch back. A copy of that copy, made by another object's bake,
keeps the record only where it holds there too: on a Shift+D copy of the object, whose mesh
shows the shared material in that slot. On a slot the artist gave the copy (Link: Object,
another material in the mesh's slot), Free puts the shared material in the slot as it is;
before, it switched the Link and the slot showed the mesh's other material (every flag +
--scene --external 950, where the mesh's slot was empty). In the mesh's slot of an object
it never holds. A copy of a clean copy whose shared material left the file gives the slot
that copy back, if it is still in the file. The record, and the object's own material behind
the mesh's, hold for the object renamed since, whose old name another object took. A Shift+D
copy freed without a bake of its own ends the same whichever Free comes first."""
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

# A copy made of a clean copy still in the file gives the slot that copy back. P and its
# Alt+D copy share a mesh showing Shared3; P's bake gives P's own slot its copy, which the
# artist gives the mesh's slot too; a save drops Shared3; P's Free leaves its copy clean in
# both (the Link record holds it). Q's mesh slot is given it; Q's bake copies it again, and
# Q's Free shows it in Q's slot again. Before, Q's copy became Shared3, which then took the
# slots of P's copy as well (every flag + --relations 144).
shared3 = in_blender.node_material("Shared3")
p = in_blender.uv_plane("P")
p.location.y = -3.0
p.data.materials.append(shared3)
p2 = in_blender.duplicate(p, linked=True)
p2.location.y = -6.0
in_blender.rain_once(p)
assert bpy.ops.hydrobake.bake(effect="rain", object_name="P") == {"FINISHED"}
p_copy = p.material_slots[0].material
assert p_copy.name == "Shared3 (P)" and p.material_slots[0].link == "OBJECT"
p.data.materials[0] = p_copy
in_blender.reopen()
assert "Shared3" not in bpy.data.materials
assert bpy.ops.hydrobake.free_bake(effect="rain", object_name="P") == {"FINISHED"}
p_copy = bpy.data.materials["Shared3 (P)"]
q = in_blender.uv_plane("Q")
q.location.y = -9.0
q.data.materials.append(p_copy)
in_blender.rain_once(q)
assert bpy.ops.hydrobake.bake(effect="rain", object_name="Q") == {"FINISHED"}
q_copy = q.material_slots[0].material
assert q_copy.name == "Shared3 (Q)", q_copy.name
assert bpy.ops.hydrobake.free_bake(effect="rain", object_name="Q") == {"FINISHED"}
shown = {o.name: o.material_slots[0].material.name for o in bpy.data.objects
         if o.name.startswith(("P", "Q"))}
assert set(shown.values()) == {"Shared3 (P)"}, shown
assert "Shared3" not in bpy.data.materials and "Shared3 (Q)" not in bpy.data.materials

# The Link record holds for the object the copy was made for after a rename, though another
# object took its old name since: R's Free switches its slot back to the mesh's. Before, the
# copy's name for its object led to that other object, and the slot stayed R's own
# (monkey --more --delete-baked --elsewhere --moves --scene 2106, 2108).
shared4 = in_blender.node_material("Shared4")
r = in_blender.uv_plane("R")
r.location.x = -3.0
r.data.materials.append(shared4)
in_blender.duplicate(r, linked=True).location.x = -6.0
in_blender.rain_once(r)
assert bpy.ops.hydrobake.bake(effect="rain", object_name="R") == {"FINISHED"}
assert r.material_slots[0].link == "OBJECT"
r.name = "R renamed"
s = in_blender.uv_plane("S")
s.location.x = -9.0
s.name = "R"
assert s.name == "R" and r.name == "R renamed"
assert bpy.ops.hydrobake.free_bake(effect="rain", object_name="R renamed") == {"FINISHED"}
for o in bpy.data.objects:
    if o.data == r.data:
        sl = o.material_slots[0]
        assert (sl.link, sl.material) == ("DATA", shared4), (o.name, sl.link, sl.material)
left = [m.name for m in bpy.data.materials if m.get("hydrobake_copy_of") == "Shared4"]
assert not left, left

# So does the object's own material behind the mesh's. T keeps Own5 behind its mesh's
# Shared5; T's rain bake copies Shared5 over it and holds Own5; T is renamed, another object
# takes the name T, and T's snow bake copies the copy again. Its Frees show the mesh's
# material with Own5 behind it, as before the bakes. Before, the second copy took the other
# object for the first one's and dropped Own5: the slot held nothing behind the mesh's.
shared5, own5 = in_blender.node_material("Shared5"), in_blender.node_material("Own5")
t = in_blender.uv_plane("T")
t.location.y = 3.0
t.data.materials.append(shared5)
in_blender.duplicate(t, linked=True).location.y = 6.0
st = t.material_slots[0]
st.link, st.material, st.link = "OBJECT", own5, "DATA"
in_blender.rain_once(t)
assert bpy.ops.hydrobake.bake(effect="rain", object_name="T") == {"FINISHED"}
t.name = "T renamed"
in_blender.uv_plane("U").name = "T"
in_blender.snow(t, (1, 1), 5.0, texture=32)
assert bpy.ops.hydrobake.bake(effect="snow", object_name="T renamed") == {"FINISHED"}
assert st.material.name == "Shared5 (T renamed)", st.material.name
for effect in ("snow", "rain"):
    assert bpy.ops.hydrobake.free_bake(effect=effect, object_name="T renamed") == {"FINISHED"}
assert (st.link, st.material) == ("DATA", shared5), (st.link, st.material)
st.link = "OBJECT"
assert st.material == own5, st.material
st.link = "DATA"

# A Shift+D copy of a baked object holds the original's record, under its name, but the
# bake's copy in its slot is not its own: whichever Free comes first, the copy's slot ends
# as the original's Free leaves another object's copy (the shared material in it, as it
# is). Before, the copy's Link went back to its mesh's only when the original was freed
# first, and took the original's own material behind it.
ends = []
for first in ("V", "V.copy"):
    shared6 = in_blender.node_material(f"Shared6 {first}")
    v = in_blender.uv_plane("V")
    v.location.y = -12.0
    v.data.materials.append(shared6)
    in_blender.duplicate(v, linked=True).location.x = 3.0
    sv = v.material_slots[0]
    sv.link, sv.material, sv.link = "OBJECT", in_blender.node_material("Own6"), "DATA"
    in_blender.rain_once(v)
    assert bpy.ops.hydrobake.bake(effect="rain", object_name="V") == {"FINISHED"}
    w = in_blender.duplicate(v)
    w.name = "V.copy"
    for name in (first, "V" if first != "V" else "V.copy"):
        assert bpy.ops.hydrobake.free_bake(effect="rain", object_name=name) == \
            {"FINISHED"}
    sw = w.material_slots[0]
    end = [sw.link, sw.material == shared6, None]
    if sw.link == "DATA":  # what it holds behind the mesh's
        sw.link = "OBJECT"
        end[2] = sw.material and sw.material.name
        sw.link = "DATA"
    ends.append(end)
    for o in [o for o in bpy.data.objects if o.name.startswith("V")]:
        bpy.data.objects.remove(o)
assert ends == [["OBJECT", True, None]] * 2, ends
print("GIVEN COPY LINK OK")
