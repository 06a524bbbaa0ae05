"""Free Bake on an object whose mesh's slot, hidden behind the object's own material (Link:
Object, switched after the bake), shows the bake's copy of a shared material on an Alt+D copy
of it. The Free put the shared material back in the mesh's slot as if nothing showed it, and
the shared one had left the file: the Alt+D copy's slot was left empty (every flag +
--relations 41). The copy shows the material again, under its own name."""
import bpy

import in_blender

in_blender.enable()
tmp = in_blender.empty_file("hidden.blend")
shared = in_blender.node_material("WaterMat")
other = in_blender.new_plane("Other")
other.data.materials.append(shared)
snowy = in_blender.uv_plane("Snowy")
snowy.data.materials.append(shared)
in_blender.snow(snowy, (1, 1), 40.0, 16)
assert bpy.ops.hydrobake.bake(effect="snow", object_name="Snowy") == {"FINISHED"}
copy = snowy.material_slots[0].material
assert copy.name == "WaterMat (Snowy)", copy.name  # own(): the bake's copy, in the mesh's slot
# The artist: an Alt+D copy of the glass, the original's slot switched to its own material,
# and the other object deleted; at a save the shared material, used by none, is dropped.
twin = in_blender.duplicate(snowy, linked=True).name
snowy.material_slots[0].link = "OBJECT"
snowy.material_slots[0].material = in_blender.node_material("OwnMat")
bpy.data.objects.remove(other)
for _ in range(2):  # (the first save still writes it: the deleted object's mesh used it)
    bpy.ops.wm.save_mainfile()
    bpy.ops.wm.revert_mainfile()
assert bpy.data.materials.get("WaterMat") is None
snowy, twin = bpy.data.objects["Snowy"], bpy.data.objects[twin]
assert twin.material_slots[0].material.name == "WaterMat (Snowy)"
assert bpy.ops.hydrobake.free_bake(effect="snow", object_name="Snowy") == {"FINISHED"}
shown = twin.material_slots[0].material
assert shown is not None, "Free emptied the Alt+D copy's slot"
assert shown.name == "WaterMat" and not any(n.get("hydrobake") for n in shown.node_tree.nodes), \
    (shown.name, shown.keys())
assert snowy.material_slots[0].link == "OBJECT" and \
    snowy.material_slots[0].material.name == "OwnMat"
print("HIDDEN COPY SHOWN OK")
