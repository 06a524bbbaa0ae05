"""A Blender 3.4.1 bug, not the addon's: Move Slot (Material panel's arrows) on an Alt+D copy
whose mesh got a slot through another of its objects after the copy was made. Blender resizes
the mesh and the object the slot was added through, not the other objects of the mesh, and
the move then writes past the copy's shorter slot array. With the guarded allocator it
segfaults every time; without, now and then (monkey --more --elsewhere --moves 4055, shrunk
from 170 actions to 14, none of them the addon's). The monkey skips such a move.

    blender -b --factory-startup --debug-memory --python slot_move_overflow.py

prints "slots ..." and then segfaults; without --debug-memory it usually prints "survived".
"""
import bpy


def select_alone(obj):
    for o in bpy.context.view_layer.objects:
        o.select_set(o == obj)
    bpy.context.view_layer.objects.active = obj


def duplicate(obj, linked):
    select_alone(obj)
    assert bpy.ops.object.duplicate(linked=linked) == {"FINISHED"}
    return bpy.context.view_layer.objects.active


def add_slot(obj, name):
    obj.active_material_index = max(0, len(obj.material_slots) - 1)
    with bpy.context.temp_override(object=obj):
        bpy.ops.object.material_slot_add()
    obj.material_slots[len(obj.material_slots) - 1].material = bpy.data.materials.new(name)


bpy.ops.mesh.primitive_plane_add()
water = bpy.context.active_object
water.data.materials.append(bpy.data.materials.new("WaterMat"))
water.material_slots[0].link = "OBJECT"
a = duplicate(water, False)
b = duplicate(a, True)
add_slot(a, "UserMat4")
duplicate(duplicate(b, False), False)
c = duplicate(a, True)
d = duplicate(c, True)
add_slot(c, "UserMat9")  # the mesh has 3 slots now, d still 2
print("slots", [(o.name, len(o.material_slots)) for o in (a, b, c, d)],
      "mesh", len(a.data.materials))
d.active_material_index = 0
with bpy.context.temp_override(object=d, active_object=d, selected_editable_objects=[d]):
    print(bpy.ops.object.material_slot_move(direction="DOWN"))
print("survived")
