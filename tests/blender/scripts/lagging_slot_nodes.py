"""An Alt+D copy whose slots lag behind its mesh's (slots added and removed through the other
object: Blender 3.4 resizes only that one there), baked: the mesh's material, which the other
object shows too, gets neither its nodes switched on nor the bake's wiring; the bake goes into
the copy's own copy of it, and Free leaves the material as it was. Snow switched the shared
material's nodes on before copying it, and they stayed on after every Free (monkey every flag
+ --scene 2161); rain wired the shared material itself. With no material at all, the one a
rain bake makes goes through own() too, as snow's does: the other object of the mesh, which
shows it, does not show the glass's drops."""
import bpy

import in_blender

in_blender.enable()


def run(op, obj, effect):
    assert getattr(bpy.ops.hydrobake, op)(effect=effect, object_name=obj.name) == {"FINISHED"}


def lagging_pair(name, make):
    """Two objects of one mesh whose slot shows a material with its nodes off; the second
    has no slot. Through the first, its slot's Link on Object: a slot added, the mesh's
    material moved down into it, the first slot removed. Blender 3.4 resizes only the
    object it works through there (every flag + --scene 2161 did it by Remove Unused
    Slots)."""
    first = make(name)
    mat = bpy.data.materials.new(f"{name}Mat")
    assert not mat.use_nodes
    first.data.materials.append(mat)
    first.material_slots[0].link = "OBJECT"
    twin = in_blender.duplicate(first, linked=True)
    with bpy.context.temp_override(object=first):
        assert bpy.ops.object.material_slot_add() == {"FINISHED"}
        first.active_material_index = 0
        assert bpy.ops.object.material_slot_move(direction="DOWN") == {"FINISHED"}
        first.active_material_index = 0
        assert bpy.ops.object.material_slot_remove() == {"FINISHED"}
    first.material_slots[0].link = "DATA"  # the first shows it too
    assert list(first.data.materials) == [mat]
    assert len(first.material_slots) == 1 and len(twin.material_slots) == 0, \
        "Blender resized the other object too: the case is not made"
    return first, twin, mat


def state(mat):
    # (the addon's settings on every material, made when first read, are no record)
    keys = sorted(k for k in mat.keys() if k not in type(mat).bl_rna.properties)
    return mat.use_nodes, keys, \
        [n.name for n in mat.node_tree.nodes if n.get("hydrobake")] if mat.node_tree else []


def case(effect, make, settings):
    in_blender.empty_file(f"lagging_{effect}.blend")
    first, twin, mat = lagging_pair(effect.title(), make)
    settings(twin)
    before = state(mat)
    run("bake", twin, effect)
    assert first.material_slots[0].material == mat
    assert mat.use_nodes is False, f"{effect}: the shared material's nodes switched on"
    assert state(mat)[2] == [], f"{effect}: the bake wired the shared material"
    shown = twin.material_slots[0].material
    assert shown != mat and shown.get("hydrobake_copy_of") == mat.name, shown
    run("free_bake", twin, effect)
    assert state(mat) == before, (effect, state(mat), before)
    assert [s.material for s in twin.material_slots] == [mat], twin.material_slots[:]
    assert [m for m in bpy.data.materials if "hydrobake_copy_of" in m] == []


def snowy(obj):
    in_blender.snow(obj, (1, 1), 100).snow.contact_mode = "BOX"


case("snow", lambda n: in_blender.new_box(n, (0.5, 0.5, 0.5), (0.0, 0.0, 0.0)), snowy)
case("rain", in_blender.uv_plane, in_blender.rain_once)
in_blender.empty_file("made_shared.blend")
glass = in_blender.uv_plane("Glass")
twin = in_blender.duplicate(glass, linked=True)
in_blender.rain_once(glass)
run("bake", glass, "rain")
made = twin.material_slots[0].material
assert made is not None and "hydrobake_made" in made, made
assert not any(n.get("hydrobake") for n in made.node_tree.nodes) if made.node_tree else True
assert glass.material_slots[0].material.get("hydrobake_copy_of") == made.name
run("free_bake", glass, "rain")
assert not glass.data.materials and not twin.material_slots, glass.data.materials[:]
assert not [m.name for m in bpy.data.materials if m.name.startswith("HBK_")]
print("LAGGING SLOT NODES OK")
