"""A Blender 3.4.1 bug, not the addon's: Remove Material Slot on an Alt+D copy whose mesh got a
slot through another of its objects after the copy was made (the copy's slots lag its mesh's,
as in slot_move_overflow.py). Blender takes a user from the material in the mesh's first slot
but leaves the material there, so it has fewer users than slots that show it; once its other
users are gone it has none, and a save drops it from the file while the mesh still shows it
(monkey --more --delete-baked --relations --no-subprocess 100: the artist's water material
gone from the pool after a reopen). The monkey skips such a remove.

    blender -b --factory-startup --python slot_remove_lagging.py

prints "users 1 ... shown by the mesh", "users 0 ... shown by the mesh", and after the reopen
"... the mesh shows [None]".
"""
import os
import tempfile

import bpy


def select_alone(obj):
    for o in bpy.context.view_layer.objects:
        o.select_set(o == obj)
    bpy.context.view_layer.objects.active = obj


bpy.ops.mesh.primitive_plane_add()
water = bpy.context.active_object
water.data.materials.append(bpy.data.materials.new("WaterMat"))
water.material_slots[0].link = "OBJECT"  # the mesh's WaterMat hidden behind the object's
select_alone(water)
bpy.ops.object.duplicate(linked=True)
copy = bpy.context.view_layer.objects.active
water.active_material_index = 0
with bpy.context.temp_override(object=water):
    bpy.ops.object.material_slot_add()  # the mesh has 2 slots now, the copy still 1


def show():
    mat = bpy.data.materials.get("WaterMat")
    print("users", mat.users if mat else None, "shown by the mesh",
          [m and m.name for m in water.data.materials])


show()
copy.active_material_index = 0
with bpy.context.temp_override(object=copy):
    bpy.ops.object.material_slot_remove()  # the first slot: WaterMat should leave the mesh
show()
name = water.name
path = os.path.join(tempfile.mkdtemp(), "lagging.blend")
bpy.ops.wm.save_as_mainfile(filepath=path)
bpy.ops.wm.open_mainfile(filepath=path)
print("after the reopen the mesh shows",
      [m and m.name for m in bpy.data.objects[name].data.materials])
