"""A baked object's material given to another baked object (Ctrl+L > Link Materials): the
other object's Free Bake leaves the first bake's wiring where it is, since that object still
records the bake; its own Free takes it out. Before, the second Free unwired every material in
its slots, and the first object, still baked, showed no drops, snow or water (monkey
--scene --external seed 900 found it with a deleted object's wiring given through Join); a
pool's Free took the water's nodes out of its ground's materials (--relations 41)."""
import bpy

import in_blender

in_blender.enable()
in_blender.empty_file("given.blend")


def glass(name, x):
    obj = in_blender.uv_plane(name)
    obj.location.x = x
    obj.data.materials.append(in_blender.node_material(f"{name}Mat"))
    s = obj.hydrobake_rain
    s.enabled, s.use_scene_range, s.frame_start, s.frame_end = True, False, 1, 1
    s.rain.cell_size = 0.05
    return obj


def snowy(name, x):
    obj = in_blender.uv_plane(name)
    obj.location.x = x
    obj.data.materials.append(in_blender.node_material(f"{name}Mat"))
    in_blender.snow(obj, (1, 1), 40.0, 16)
    return obj


def pool(name, x):
    ground = in_blender.uv_plane(f"{name}Ground")
    ground.location = (x, 0.0, -0.4)
    ground.data.materials.append(in_blender.node_material(f"{name}GroundMat"))
    obj = in_blender.new_plane(name)
    obj.location.x = x
    obj.data.materials.append(in_blender.node_material(f"{name}Mat"))
    c = obj.hydrobake_caustics
    c.enabled, c.ground_object = True, ground
    c.use_scene_range, c.frame_start, c.frame_end = False, 1, 1
    c.water.width, c.map_resolution = 16, 32
    return obj


CASES = {"rain": (glass, "rain.", "rain_normal"), "snow": (snowy, "snow.", "snow_coverage"),
         "caustics": (pool, "caustics.", "surface")}


def shows(mat, prefix, image):
    return sorted(n.image.name for n in mat.node_tree.nodes
                  if str(n.get("hydrobake", "")).startswith(prefix) and
                  getattr(n, "image", None) is not None and n.image.name == image)


def link_materials(src, dst):
    """Ctrl+L > Link Materials from ``src`` (active) to ``dst`` (selected)."""
    bpy.context.view_layer.update()  # (objects just linked are not the view layer's before)
    in_blender.select_alone(src, also=dst)
    assert bpy.ops.object.make_links_data(type="MATERIAL") == {"FINISHED"}


for x, (effect, (make, prefix, stream)) in enumerate(CASES.items()):
    a, b = make(f"{effect}A", 6.0 * x), make(f"{effect}B", 6.0 * x + 3.0)
    for obj in (a, b):
        assert bpy.ops.hydrobake.bake(effect=effect, object_name=obj.name) == {"FINISHED"}
    mat_a = a.material_slots[0].material
    image = f"HBK_{a.name}_{stream}"
    assert shows(mat_a, prefix, image) == [image], (effect, mat_a.name)
    link_materials(a, b)
    assert b.material_slots[0].material == mat_a, effect
    assert bpy.ops.hydrobake.free_bake(effect=effect, object_name=b.name) == {"FINISHED"}
    # a still records its bake, and its material still shows it
    assert getattr(a, f"hydrobake_{effect}").is_baked, effect
    assert shows(mat_a, prefix, image) == [image], \
        f"{effect}: {b.name}'s Free took {a.name}'s wiring out of {mat_a.name}"
    assert bpy.data.images.get(image) is not None, effect
    assert bpy.ops.hydrobake.free_bake(effect=effect, object_name=a.name) == {"FINISHED"}
    left = [n.name for n in mat_a.node_tree.nodes if n.get("hydrobake")]
    assert not left, f"{effect}: {a.name}'s Free left {left} in {mat_a.name}"
    assert "hydrobake_saved" not in mat_a, (effect, mat_a.keys())

# The same where a Shift+D copy lets go of a record another object holds (let_go): a copy of
# a baked glass, given a third glass's material, is freed.
a, e = glass("CopiedA", 20.0), glass("OtherE", 23.0)
for obj in (a, e):
    assert bpy.ops.hydrobake.bake(effect="rain", object_name=obj.name) == {"FINISHED"}
c = in_blender.duplicate(a)
assert c.hydrobake_rain.is_baked
mat_e, image = e.material_slots[0].material, "HBK_OtherE_rain_normal"
link_materials(e, c)
assert bpy.ops.hydrobake.free_bake(effect="rain", object_name=c.name) == {"FINISHED"}
assert a.hydrobake_rain.is_baked and not c.hydrobake_rain.is_baked
assert shows(mat_e, "rain.", image) == [image], \
    f"{c.name}'s Free took {e.name}'s wiring out of {mat_e.name}"
assert shows(a.material_slots[0].material, "rain.", "HBK_CopiedA_rain_normal")

# A baked pool's material given to another pool's ground: that pool's Free takes its caustics
# out of the ground's materials, and before owners were recorded, every owner-less node of
# theirs with them. A water's surface nodes have no owner either (every flag + --relations 41,
# where a Join put them on the ground).
p, q = pool("PoolP", 30.0), pool("PoolQ", 33.0)
for obj in (p, q):
    assert bpy.ops.hydrobake.bake(effect="caustics", object_name=obj.name) == {"FINISHED"}
mat_q, image = q.material_slots[0].material, "HBK_PoolQ_surface"
link_materials(q, p.hydrobake_caustics.ground_object)
assert bpy.ops.hydrobake.free_bake(effect="caustics", object_name=p.name) == {"FINISHED"}
assert shows(mat_q, "caustics.", image) == [image], \
    f"{p.name}'s Free took {q.name}'s surface out of {mat_q.name}, given to its ground"
assert bpy.ops.hydrobake.free_bake(effect="caustics", object_name=q.name) == {"FINISHED"}
assert not [n.name for n in mat_q.node_tree.nodes if n.get("hydrobake")]
# ... while a floor's nodes from before owners (a file of then) still go with the pool's Free.
r = pool("PoolR", 36.0)
assert bpy.ops.hydrobake.bake(effect="caustics", object_name=r.name) == {"FINISHED"}
floor = r.hydrobake_caustics.ground_object.material_slots[0].material
old = [n for n in floor.node_tree.nodes if n.get("hydrobake_owner") == r.name]
assert old
for n in old:
    del n["hydrobake_owner"]
assert bpy.ops.hydrobake.free_bake(effect="caustics", object_name=r.name) == {"FINISHED"}
left = [n.name for n in floor.node_tree.nodes if n.get("hydrobake")]
assert not left, f"{r.name}'s Free left its owner-less floor nodes {left}"
print("GIVEN WIRING OK")
