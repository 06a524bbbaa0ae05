"""A clean copy the artist gave an Alt+D mesh's slot, under the copy a bake of one of its
objects made over it on the object's own slot: the Free that frees the first copy's bake
puts the second back, which shows the first again, and that one goes back to the shared
material in the same Free. Before, it stayed in the mesh's slot until some later Free of any
object (every flag + --relations 128, where the harness's snapshot with nothing baked took it
in and the next Free changed it)."""
import bpy

import in_blender

in_blender.enable()
in_blender.empty_file("revealed.blend")

mat = in_blender.node_material("Shared")

# S (snow) and X share the material: S's bake gives S its copy "Shared (S)", wired by snow.
s = in_blender.uv_plane("S")
s.data.materials.append(mat)
in_blender.snow(s, (1, 1), 200.0)
x = in_blender.uv_plane("X")
x.location.x = 3.0
x.data.materials.append(mat)
assert bpy.ops.hydrobake.bake(effect="snow", object_name="S") == {"FINISHED"}
s_copy = s.material_slots[0].material
assert s_copy.name == "Shared (S)" and s_copy["hydrobake_copy_of"] == "Shared"

# G and its Alt+D copy G2 share a mesh; the artist gives the mesh's slot S's copy. Their
# rain bakes make their own copies over it, on their own slots, S's snow copied along (so no
# object shows the mesh's slot, where a later object's turn would have put it back).
g = in_blender.uv_plane("G")
g.location.x = 6.0
g.data.materials.append(s_copy)
g2 = in_blender.duplicate(g, linked=True)
g2.location.x = 9.0
for o in (g, g2):
    in_blender.rain_once(o)
    assert bpy.ops.hydrobake.bake(effect="rain", object_name=o.name) == {"FINISHED"}
    slot = o.material_slots[0]
    assert slot.link == "OBJECT" and slot.material.name == f"Shared ({o.name})", \
        (slot.link, slot.material.name)

# Their Frees leave their copies (S's snow is in them); S's Free takes that out, so the
# copies go, the mesh's slot shows S's copy, clean now, and it goes back to the shared
# material too.
for o in (g, g2):
    assert bpy.ops.hydrobake.free_bake(effect="rain", object_name=o.name) == {"FINISHED"}
    assert o.material_slots[0].link == "OBJECT"
assert bpy.ops.hydrobake.free_bake(effect="snow", object_name="S") == {"FINISHED"}
for o in (s, x, g, g2):
    sl = o.material_slots[0]
    assert sl.link == "DATA" and sl.material == mat, (o.name, sl.link, sl.material.name)
left = [m.name for m in bpy.data.materials if "hydrobake_copy_of" in m]
assert not left, left
print("REVEALED COPY OK")
