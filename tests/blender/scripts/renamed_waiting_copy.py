"""An Alt+D copy's snow bake, renamed, its clean copy waiting after its Free, and its old name
taken by another object: the slot it switched to Link: Object goes back to Data when the
shared material comes back. The copy's record named the old name, whose new holder was not
the object, so the Free that came later left Link on Object (monkey every flag + all three
+ --renames 865)."""
import bpy

import in_blender

in_blender.enable()


def run(op, obj, effect):
    assert getattr(bpy.ops.hydrobake, op)(effect=effect, object_name=obj.name) == {"FINISHED"}


def slots(obj):
    return [(s.link, s.material.name if s.material else None) for s in obj.material_slots]


def case(taken_before):
    """The old name taken before the object's Free, or between it and the pool's."""
    in_blender.empty_file(f"renamed_waiting_{taken_before}.blend")
    for data in (bpy.data.meshes, bpy.data.materials, bpy.data.images):
        for block in list(data):
            data.remove(block)
    shared = in_blender.node_material("Shared")
    ground = in_blender.new_plane("Ground")  # Shared is a pool's ground too
    ground.scale, ground.location = (3.0, 3.0, 1.0), (0.0, 0.0, -0.5)
    ground.data.materials.append(shared)
    pool = in_blender.new_plane("Pool")
    pool.data.materials.append(in_blender.node_material("Water"))
    s = pool.hydrobake_caustics
    s.enabled, s.ground_object = True, ground
    s.use_scene_range, s.frame_start, s.frame_end = False, 1, 1
    s.water.width, s.map_resolution = 16, 32
    rock = in_blender.new_box("Rock", (0.5, 0.5, 0.5), (20.0, 0.0, 0.0))
    rock.data.materials.append(shared)
    in_blender.snow(rock, (1, 1), 100).snow.contact_mode = "BOX"
    twin = in_blender.duplicate(rock, linked=True)  # shows Shared through the mesh

    run("bake", rock, "snow")  # the mesh is shared: the copy goes on the rock's own slot
    assert slots(rock) == [("OBJECT", "Shared (Rock)")], slots(rock)
    run("bake", pool, "caustics")  # the pool's floor nodes go into Shared (the ground's)
    rock.name = "Boulder"
    if taken_before:
        in_blender.new_plane("Rock")  # another object takes the old name
    run("free_bake", rock, "snow")
    assert slots(rock) == [("OBJECT", "Shared (Rock)")], slots(rock)  # waits for the floor
    if not taken_before:
        in_blender.new_plane("Rock")
    run("free_bake", pool, "caustics")
    assert slots(rock) == [("DATA", "Shared")], (taken_before, slots(rock))  # as before
    assert slots(twin) == [("DATA", "Shared")], slots(twin)
    assert "Shared (Rock)" not in bpy.data.materials


case(taken_before=True)
case(taken_before=False)
print("RENAMED WAITING COPY OK")
