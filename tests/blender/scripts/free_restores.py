"""Free Bake puts materials back as they were (the monkey test's findings), one case per run:

    blender -b --python free_restores.py -- TMPDIR CASE

Prints ``FREE RESTORES <case> OK`` or ``FREE RESTORES <case> FAIL <what>``."""
import os

import bpy

import in_blender

in_blender.enable()
tmp, case = in_blender.args()[:2]
bpy.ops.wm.save_as_mainfile(filepath=os.path.join(tmp, "r.blend"))
for o in list(bpy.data.objects):
    bpy.data.objects.remove(o)
problems = []


def check(ok, what):
    if not ok:
        problems.append(what)


def plane(name, size=0.5, loc=(0, 0, 0), uv=True):
    o = in_blender.new_plane(name)
    o.scale, o.location = (size, size, 1), loc
    if uv:
        layer = o.data.uv_layers.new(name="UVMap")
        for loop, c in zip(layer.data, ((0, 0), (1, 0), (1, 1), (0, 1))):
            loop.uv = c
    return o


def pool():
    g = plane("Ground", 1.5, (0, 0, -0.4))
    g.data.materials.append(in_blender.node_material("GroundMat"))
    w = plane("Water", 1.0, uv=False)
    s = w.hydrobake_caustics
    s.enabled, s.ground_object = True, g
    s.use_scene_range, s.frame_start, s.frame_end = False, 1, 3
    s.water.width, s.map_resolution = 16, 32
    return w


def glass(name="Glass", mat="GlassMat", loc=(3, 0, 1)):
    o = plane(name, 0.5, loc)
    if mat:
        o.data.materials.append(bpy.data.materials.get(mat) or in_blender.node_material(mat))
    s = o.hydrobake_rain
    s.enabled, s.rain.cell_size = True, 0.05
    s.use_scene_range, s.frame_start, s.frame_end = False, 1, 3
    return o


def bake(name, effect):
    assert bpy.ops.hydrobake.bake(effect=effect, object_name=name) == {"FINISHED"}


def free(name, effect):
    try:
        return bpy.ops.hydrobake.free_bake(effect=effect, object_name=name)
    except RuntimeError as e:
        problems.append(f"Free of {name} raised {str(e).splitlines()[-1]}")


def tagged(m):
    return [n.get("hydrobake") for n in m.node_tree.nodes if n.get("hydrobake")] \
        if m.node_tree else []


def state(m):
    """What Free Bake must give back: nodes, links, the shader's values, the custom props,
    the EEVEE settings a bake sets for a refracting surface."""
    bsdf = next((n for n in m.node_tree.nodes if n.type == "BSDF_PRINCIPLED"), None)
    return (m.use_nodes, m.blend_method, m.use_screen_refraction,
            sorted(n.name for n in m.node_tree.nodes), len(m.node_tree.links),
            tuple(round(bsdf.inputs[k].default_value, 6) for k in
                  ("Roughness", "IOR", "Transmission")) if bsdf else None,
            sorted(k for k in m.keys() if k.startswith("hydrobake") and
                   k != "hydrobake_snow"))  # the settings of a material snow reads


def slots():
    return {o.name: [s.material.name if s.material else None for s in o.material_slots]
            for o in bpy.data.objects if o.type == "MESH"}


def clean():
    """Nothing of any bake left: no tagged node, no HBK material or image with users, no
    material copy."""
    for m in bpy.data.materials:
        check(not tagged(m), f"{m.name} keeps wiring {tagged(m)}")
        check(not m.name.startswith("HBK"), f"{m.name} left ({m.users} users)")
        check("hydrobake_copy_of" not in m, f"copy {m.name} left ({m.users} users)")
    for i in bpy.data.images:
        if i.name.startswith("HBK") and i.users:
            users = [u.name for u in bpy.data.user_map(subset=[i])[i]]
            problems.append(f"image {i.name} keeps {i.users} users {users}")


if case == "hidden":  # 1: a hidden object, and one in no view layer
    w = pool()
    g = glass(mat=None)
    bake("Water", "caustics")
    bake("Glass", "rain")
    w.hide_viewport = True
    for c in list(g.users_collection):
        c.objects.unlink(g)
    free("Water", "caustics")
    free("Glass", "rain")
    check(not w.hydrobake_caustics.is_baked and not g.hydrobake_rain.is_baked, "still baked")
    check(slots() == {"Ground": ["GroundMat"], "Water": [], "Glass": []}, f"slots {slots()}")
    clean()
elif case == "slot_changed":  # 2: the baked material replaced in its slot, or its slot removed
    g = glass()
    h = glass("Pane", "PaneMat", (5, 0, 1))
    before = {n: state(bpy.data.materials[n]) for n in ("GlassMat", "PaneMat")}
    bake("Glass", "rain")
    bake("Pane", "rain")
    for name in ("GlassMat", "PaneMat"):  # EEVEE sees through the glass (Cycles reads neither)
        m = bpy.data.materials[name]
        check(m.blend_method == "BLEND" and m.use_screen_refraction, f"{name} opaque in EEVEE")
    g.material_slots[0].material = in_blender.node_material("Other")
    h.data.materials.pop(index=0)
    free("Glass", "rain")
    free("Pane", "rain")
    for name, was in before.items():
        m = bpy.data.materials[name]
        check(state(m) == was, f"{name} is {state(m)}, was {was}")
    clean()
elif case in ("copy_made", "copy_made_copy_first"):  # 5: a material the bake made, in a
    g = glass(mat=None)                                 # Shift+D copy of the object
    bake("Glass", "rain")
    in_blender.duplicate(g)
    for name in ("Glass", "Glass.001")[::1 if case == "copy_made" else -1]:
        free(name, "rain")
    check(slots() == {"Glass": [], "Glass.001": []}, f"slots {slots()}")
    clean()
elif case == "copy_made_rebaked":  # 5: ... the copy's own bake in a copy of the material
    g = glass(mat=None)
    bake("Glass", "rain")
    in_blender.duplicate(g)
    free("Glass.001", "rain")
    bake("Glass.001", "rain")
    check(slots()["Glass.001"] == ["HBK_Glass_glass (Glass.001)"], f"slots {slots()}")
    free("Glass", "rain")
    free("Glass.001", "rain")
    check(slots() == {"Glass": [], "Glass.001": []}, f"slots {slots()}")
    clean()
elif case == "copy_made_original_deleted":  # 5: ... the original deleted first (its mesh,
    g = glass(mat=None)                         # used by nothing, still holds the material)
    bake("Glass", "rain")
    in_blender.duplicate(g)
    bpy.data.objects.remove(g)
    free("Glass.001", "rain")
    check(slots() == {"Glass.001": []}, f"slots {slots()}")
    check("HBK_Glass_glass" not in bpy.data.materials, "the made material stayed")
    clean()
elif case == "copy_original_deleted":  # 9: a Shift+D copy baked, the original deleted while
    g = glass()                            # baked: the shared materials keep its wiring; the
    g.data.materials.append(in_blender.node_material("FritMat"))  # copy's Free keeps its clean
    bake("Glass", "rain")                  # copies, and so does another object's Free (seed 244)
    g.name = "Glass1"
    c = in_blender.duplicate(g)
    bake(c.name, "rain")
    bpy.data.objects.remove(g)
    bpy.ops.wm.save_mainfile()
    o = plane("Snowy", 0.5, (-3, 0, 0))
    in_blender.snow(o, (1, 3), 40.0, 16)
    bake("Snowy", "snow")
    free(c.name, "rain")
    free("Snowy", "snow")
    mine = ["GlassMat (Glass1.001)", "FritMat (Glass1.001)"]
    check(slots()[c.name] == mine, f"slots {slots()}")
    check(not any(tagged(bpy.data.materials[m]) for m in mine if m in bpy.data.materials),
          "the copy shows wiring")
    # File > Clean Up > Remove Deleted Objects' Bakes: the shared ones are clean, they are
    # back in the copy's slots.
    assert bpy.ops.hydrobake.remove_deleted_bakes() == {"FINISHED"}
    check(slots()[c.name] == ["GlassMat", "FritMat"], f"slots after the removal {slots()}")
    clean()
elif case == "copy_made_original_deleted_removed":  # 13: a Shift+D copy of a glass given a
    g = glass(mat=None)                                # made material, baked; the original
    bake("Glass", "rain")                              # deleted while baked, the copy freed
    c = in_blender.duplicate(g)                        # (its clean copy goes: the made one,
    bake(c.name, "rain")                               # wired, is only the deleted one's, as
    bpy.data.objects.remove(g)                         # after a save: 3184), then the deleted
    free(c.name, "rain")                               # one's bake removed (monkey seed 650)
    check(slots() == {c.name: []}, f"slots {slots()}")
    assert bpy.ops.hydrobake.remove_deleted_bakes() == {"FINISHED"}
    check(slots() == {c.name: []}, f"slots after the removal {slots()}")
    clean()
elif case == "copy_made_swapped":  # 5: ... taken out of the copy's slot before its Free
    g = glass(mat=None)
    bake("Glass", "rain")
    in_blender.duplicate(g)
    free("Glass", "rain")
    bpy.data.objects["Glass.001"].material_slots[0].material = in_blender.node_material("M")
    free("Glass.001", "rain")
    check(slots() == {"Glass": [], "Glass.001": ["M"]}, f"slots {slots()}")
    clean()
elif case == "shared_two":  # 3: two objects sharing a material, both baked, both freed
    a = glass()
    b = glass("Glass B", "GlassMat", (5, 0, 1))
    before = state(bpy.data.materials["GlassMat"])
    bake("Glass", "rain")
    bake("Glass B", "rain")
    free("Glass", "rain")
    free("Glass B", "rain")
    check(slots() == {"Glass": ["GlassMat"], "Glass B": ["GlassMat"]}, f"slots {slots()}")
    check(state(bpy.data.materials["GlassMat"]) == before, "GlassMat changed")
    clean()
elif case == "copy_rebake":  # 3: a Shift+D copy, the original re-baked, both freed
    g = glass()
    before = state(bpy.data.materials["GlassMat"])
    bake("Glass", "rain")
    in_blender.duplicate(g)
    bake("Glass", "rain")
    free("Glass", "rain")
    free("Glass.001", "rain")
    check(slots() == {"Glass": ["GlassMat"], "Glass.001": ["GlassMat"]}, f"slots {slots()}")
    check(state(bpy.data.materials["GlassMat"]) == before, "GlassMat changed")
    clean()
elif case == "copy_free_rebake":  # 4: copy freed, the original re-baked and freed
    o = plane("Snowy", 0.5, (-3, 0, 0))
    o.data.materials.append(in_blender.node_material("SnowyMat"))
    in_blender.snow(o, (1, 3), 40.0, 16)
    before = state(bpy.data.materials["SnowyMat"])
    bake("Snowy", "snow")
    in_blender.duplicate(o)
    free("Snowy.001", "snow")
    bake("Snowy", "snow")
    free("Snowy", "snow")
    check(not any(x.hydrobake_snow.is_baked for x in bpy.data.objects), "still baked")
    check(slots() == {"Snowy": ["SnowyMat"], "Snowy.001": ["SnowyMat"]}, f"slots {slots()}")
    check(state(bpy.data.materials["SnowyMat"]) == before,
          f"SnowyMat is {state(bpy.data.materials['SnowyMat'])}, was {before}")
    clean()
elif case == "shared_nodeless":  # 6: a shared material that never had nodes, one baked
    plain = bpy.data.materials.new("Plain")  # no node tree until nodes are turned on
    for name, x in (("Snowy", -3), ("Snowy B", -5)):
        o = plane(name, 0.5, (x, 0, 0))
        o.data.materials.append(plain)
    in_blender.snow(bpy.data.objects["Snowy"], (1, 3), 40.0, 16)
    bake("Snowy", "snow")
    check(slots() == {"Snowy": ["Plain (Snowy)"], "Snowy B": ["Plain"]}, f"slots {slots()}")
    check(tagged(bpy.data.materials["Plain (Snowy)"]), "the copy is not wired")
    free("Snowy", "snow")
    check(slots() == {"Snowy": ["Plain"], "Snowy B": ["Plain"]}, f"slots {slots()}")
    check(not plain.use_nodes and plain.node_tree is None, "Plain got nodes")
    clean()
elif case == "shared_nodeless_pool":  # 8: ... the material of two pools (monkey seed 204)
    w = pool()
    plain = bpy.data.materials.new("Plain")
    w.data.materials.append(plain)
    in_blender.duplicate(w)
    bake("Water", "caustics")
    check(slots()["Water"] == ["Plain (Water)"], f"slots {slots()}")
    check(not plain.use_nodes and plain.node_tree is None, "Bake turned Plain's nodes on")
    free("Water", "caustics")
    check(slots()["Water"] == ["Plain"] == slots()["Water.001"], f"slots {slots()}")
    check(not plain.use_nodes and not plain.keys(), f"Plain keeps {list(plain.keys())}")
    clean()
elif case == "floor_replaced":  # 10: the floor material the bake made replaced in its slot
    w = pool()                    # (monkey seed 312)
    g = bpy.data.objects["Ground"]
    g.data.materials.clear()
    bake("Water", "caustics")
    check(slots()["Ground"] == ["HBK_Ground_floor"], f"slots {slots()}")
    g.material_slots[0].material = in_blender.node_material("Other")
    free("Water", "caustics")
    check("HBK_Ground_floor" not in bpy.data.materials, "the made floor material stayed")
    check(slots()["Ground"] == ["Other"], f"slots {slots()}")
    clean()
elif case == "pool_over_pool":  # 11: a pool whose ground is another pool of its material
    w = pool()                  # (monkey seed 312)
    w.data.materials.append(in_blender.node_material("WaterMat"))
    before = state(bpy.data.materials["WaterMat"])
    other = in_blender.duplicate(w)
    w.hydrobake_caustics.ground_object = other
    bake("Water", "caustics")
    check(slots()["Water"] == ["WaterMat (Water)"] and
          tagged(bpy.data.materials["WaterMat"]), f"slots {slots()}")
    check(bpy.data.materials["WaterMat (Water)"].use_screen_refraction, "water opaque in EEVEE")
    free("Water", "caustics")
    check(slots()["Water"] == ["WaterMat"] == slots()[other.name], f"slots {slots()}")
    check(state(bpy.data.materials["WaterMat"]) == before, "WaterMat changed")
    clean()
elif case == "ground_copy_baked":  # 12: a Shift+D copy of a ground given a floor material
    w = pool()                     # holds a bake of another effect (monkey seed 477)
    g = bpy.data.objects["Ground"]
    g.data.materials.clear()  # the bake makes the floor's material
    fill = plane("Fill", 0.3, (0, 0, -0.4))
    import bmesh
    for o in (g, fill):  # boxes: the ground is a fluid domain, the fill its water
        bm = bmesh.new()
        bmesh.ops.create_cube(bm, size=1.0)
        bm.to_mesh(o.data)
        bm.free()
    bake("Water", "caustics")
    check(slots()["Ground"] == ["HBK_Ground_floor"], f"slots {slots()}")
    copy = in_blender.duplicate(g)
    s = copy.hydrobake_fluid
    s.enabled, s.fill_object = True, fill
    s.fluid.resolution, s.fluid.textures = (8, 8, 8), 1
    s.use_scene_range, s.frame_start, s.frame_end = False, 1, 2
    bake(copy.name, "fluid")
    free("Water", "caustics")
    check(slots()["Ground"] == [] and slots()[copy.name] == [], f"slots {slots()}")
    free(copy.name, "fluid")
    for m in [m for m in bpy.data.materials if m.users == 0 and m.name.startswith(
            f"HBK_{copy.name}_")]:  # a fluid's textured materials, kept for a re-bake
        bpy.data.materials.remove(m)
    clean()
elif case == "shared_vanished":  # 7: the shared material left the file before the Free
    for name, x in (("Snowy", -3), ("Snowy B", -5)):
        o = plane(name, 0.5, (x, 0, 0))
        o.data.materials.append(bpy.data.materials.get("Felt") or in_blender.node_material("Felt"))
    in_blender.snow(bpy.data.objects["Snowy B"], (1, 3), 40.0, 16)
    bake("Snowy B", "snow")  # Snowy shows Felt too: Snowy B gets its own copy
    bpy.data.objects["Snowy"].material_slots[0].material = in_blender.node_material("Other")
    bpy.ops.wm.save_mainfile()  # Felt, used by nothing, is not saved
    bpy.ops.wm.open_mainfile(filepath=bpy.data.filepath)
    check("Felt" not in bpy.data.materials, "Felt was saved")
    free("Snowy B", "snow")
    check(slots()["Snowy B"] == ["Felt"], f"slots {slots()}")
    check(not any(k.startswith("hydrobake_copy") for k in bpy.data.materials["Felt"].keys()),
          "Felt still says it is a copy")
    clean()
elif case == "shared_vanished_other_wired":  # 19: as 7, the copy also a pool's floor; the
    # pool freed last, after the glass (monkey 767: the copy stood for nothing, under its name)
    w = pool()
    g = glass(mat="GroundMat", loc=(0, 0, -0.3))  # Ground shows GroundMat too: Glass's copy
    w.hydrobake_caustics.ground_object = g
    bake("Glass", "rain")
    bake("Water", "caustics")  # the floor's nodes go into Glass's copy
    bpy.data.objects["Ground"].material_slots[0].material = in_blender.node_material("Other")
    bpy.ops.wm.save_mainfile()  # GroundMat, used by nothing, is not saved
    bpy.ops.wm.open_mainfile(filepath=bpy.data.filepath)
    check("GroundMat" not in bpy.data.materials, "GroundMat was saved")
    free("Glass", "rain")  # the copy keeps the pool's floor: still a copy
    free("Water", "caustics")
    check(slots()["Glass"] == ["GroundMat"], f"slots {slots()}")
    check(not any(k.startswith("hydrobake_copy") for k in
                  getattr(bpy.data.materials.get("GroundMat"), "keys", dict)()),
          "GroundMat still says it is a copy")
    clean()
elif case == "slot_link_object":  # 20: the made material's slot switched to the object's own
    # material after the bake (Link: Object): the mesh's slot still holds it (monkey 1029)
    w = pool()
    bake("Water", "caustics")
    w.material_slots[0].link = "OBJECT"
    free("Water", "caustics")
    check(slots()["Water"] == [] and len(w.data.materials) == 0,
          f"slots {slots()}, mesh {list(w.data.materials)}")
    clean()
elif case == "slot_link_data":  # 20b: the ground's slot switched to the object's own (none)
    # before the bake, the floor made there, then switched back to the mesh's (monkey 1030)
    w = pool()
    g = bpy.data.objects["Ground"]
    g.material_slots[0].link = "OBJECT"
    bake("Water", "caustics")
    g.material_slots[0].link = "DATA"
    free("Water", "caustics")
    g.material_slots[0].link = "OBJECT"
    check(g.material_slots[0].material is None, f"own {g.material_slots[0].material}")
    g.material_slots[0].link = "DATA"
    check(slots()["Ground"] == ["GroundMat"], f"slots {slots()}")
    clean()
elif case == "slot_link_rebake":  # 20c: the made material's slot switched to the object's
    # own (none) and re-baked: the made one in both the mesh's slot and the object's (1011)
    g = glass(mat=None)
    bake("Glass", "rain")
    g.material_slots[0].link = "OBJECT"
    bake("Glass", "rain")  # in place
    free("Glass", "rain")
    check(not any(g.data.materials) and not any(s.material for s in g.material_slots),
          f"mesh {list(g.data.materials)}, slots {slots()}")
    clean()
elif case == "linked_copies":  # 21: two Alt+D copies (one mesh), each baked and freed in
    # turns, one's own material set to none between (monkey 1009, 1006)
    g = glass(mat=None)
    bake("Glass", "rain")
    g2 = in_blender.duplicate(g, linked=True)
    bake(g2.name, "rain")  # the mesh's slot shows Glass's: Glass.001 gets its own copy
    free("Glass", "rain")
    bake("Glass", "rain")
    g2.material_slots[0].material = None
    bake(g2.name, "rain")
    free("Glass", "rain")
    free(g2.name, "rain")
    check(slots() == {"Glass": [], g2.name: []}, f"slots {slots()}")
    check(not g.data.keys(), f"the mesh keeps {g.data.keys()}")
    # The other way round: the copy's made material first, the original's own copy after.
    bake(g2.name, "rain")
    bake("Glass", "rain")
    free("Glass", "rain")
    free(g2.name, "rain")
    check(slots() == {"Glass": [], g2.name: []}, f"slots {slots()}")
    check(not g.data.keys(), f"the mesh keeps {g.data.keys()}")
    # The artist's slot after the made one: that one stays, empty, and nothing marks it
    # (monkey 1007, 1012).
    bake("Glass", "rain")
    bake(g2.name, "rain")
    g.data.materials.append(in_blender.node_material("Artist"))
    free("Glass", "rain")
    free(g2.name, "rain")
    check(slots() == {"Glass": [None, "Artist"], g2.name: [None, "Artist"]}, f"slots {slots()}")
    check(not g.data.keys(), f"the mesh keeps {g.data.keys()}")
    clean()
elif case == "linked_pool":  # 22: an Alt+D copy of a pool without a material baked: the
    # material made for it shows on the mesh's other object at once (monkey 1017)
    w = pool()
    w2 = in_blender.duplicate(w, linked=True)
    bake(w2.name, "caustics")
    free(w2.name, "caustics")
    check(slots()["Water"] == [] and slots()[w2.name] == [], f"slots {slots()}")
    clean()
elif case == "linked_pool_copied":  # 23: as 22, with a Shift+D copy of the mesh's other
    # object made while baked: it shows the made material in a mesh of its own (1056)
    w = pool()
    w2 = in_blender.duplicate(w, linked=True)
    bake(w2.name, "caustics")
    w3 = in_blender.duplicate(w)
    free(w2.name, "caustics")
    check(all(slots()[o.name] == [] for o in (w, w2, w3)), f"slots {slots()}")
    clean()
elif case == "floor_taken_off":  # 24: the ground's node-less material, given the pool's
    # floor nodes (switched on), taken off the ground before the pool is re-baked (1033)
    w = pool()
    floor = bpy.data.materials["GroundMat"]
    floor.use_nodes = False
    bake("Water", "caustics")
    check(floor.use_nodes, "the floor's nodes were not switched on")
    bpy.data.objects["Ground"].material_slots[0].material = in_blender.node_material("Other")
    bake("Water", "caustics")  # in place: the floor now Other's
    free("Water", "caustics")
    check(not floor.use_nodes and not [k for k in floor.keys() if k.startswith("hydrobake")],
          f"GroundMat: nodes {floor.use_nodes}, {floor.keys()}")
    clean()
elif case == "copy_hidden_by_link":  # 25: an object's own copy of a shared material hidden
    # by its slot's Link switched after the bake: in the mesh's slot, then in the object's
    # own (monkey --more 1069)
    g = glass(mat="GlassMat")
    glass("Pane", "GlassMat", (5, 0, 1))  # GlassMat shared: Glass gets its own copy
    bake("Glass", "rain")
    g.material_slots[0].link = "OBJECT"
    free("Glass", "rain")
    g.material_slots[0].link = "DATA"
    check(slots()["Glass"] == ["GlassMat"], f"slots {slots()}")
    w = pool()
    w2 = in_blender.duplicate(w, linked=True)
    bake("Water", "caustics")  # the mesh is Water.001's too: Water's own copy, Link: Object
    w.material_slots[0].link = "DATA"
    free("Water", "caustics")
    check(slots()["Water"] == [] and slots()[w2.name] == [], f"slots {slots()}")
    clean()
elif case == "made_hidden_in_copy":  # 26: a pool's made material hidden by its slot's Link
    # (set to Object after the bake) in the mesh of a Shift+D copy holding its record (1075)
    w = pool()
    bake("Water", "caustics")
    w.material_slots[0].link = "OBJECT"
    w2 = in_blender.duplicate(w)
    bake("Water", "caustics")  # in place: the made one at the object's own, too
    free("Water", "caustics")
    free(w2.name, "caustics")
    clean()
elif case == "copy_hidden_in_freed_copy":  # 27: a Shift+D copy of a pool with its own
    # copy of the made material (Link: Object, the mesh shared by an Alt+D copy), freed, its
    # Link switched to Data; the pool freed last (monkey --more 1062)
    w = pool()
    in_blender.duplicate(w, linked=True)
    bake("Water", "caustics")
    w3 = in_blender.duplicate(w)
    free(w3.name, "caustics")
    w3.material_slots[0].link = "DATA"
    free("Water", "caustics")
    clean()
elif case == "linked_copy_of_baked":  # 28: an Alt+D copy of a pool baked with its mesh
    # shared (the made material in the mesh's slot, the pool's own copy of it at Link: Object),
    # freed first: the mesh keeps the made one the pool's copy stands for (monkey --more 1106)
    w = pool()
    w2 = in_blender.duplicate(w, linked=True)
    bake("Water", "caustics")
    bpy.data.objects.remove(w2)
    w3 = in_blender.duplicate(w, linked=True)
    free(w3.name, "caustics")
    check(w.data.materials[0] is not None, f"the mesh's made material went: {slots()}")
    free("Water", "caustics")
    check(slots() == {"Ground": ["GroundMat"], "Water": [], w3.name: []}, f"slots {slots()}")
    clean()
elif case == "linked_copy_then_copy":  # 29: a pool without a material, baked with an Alt+D
    # copy (the made material in the mesh's slot, the pool's own copy of it at Link: Object),
    # Shift+D copied (its own mesh, showing the same copy), the Alt+D copy baked too; freed
    # pool first: the mesh's slot made for the bake goes too (monkey --more 3020)
    w = pool()
    w2 = in_blender.duplicate(w, linked=True)
    bake("Water", "caustics")
    w3 = in_blender.duplicate(w)
    bake(w2.name, "caustics")
    for name in ("Water", w2.name, w3.name):
        free(name, "caustics")
    check(slots() == {"Ground": ["GroundMat"], "Water": [], w2.name: [], w3.name: []},
          f"slots {slots()}")
    check("hydrobake_empty_slot" not in w.data, "the mesh keeps its empty-slot mark")
    clean()
elif case == "made_copy_deleted_baked":  # 30: a glass without a material baked (a made
    # material appended), Shift+D copied, baked again (its own copy of the made one, which
    # the copy shows), the copy baked and deleted while baked (its mesh, used by nothing,
    # keeps the made one with its wiring): the glass's Free leaves no slot (monkey
    # --delete-baked 3184)
    g = glass(mat=None)
    bake("Glass", "rain")
    c = in_blender.duplicate(g)
    bake("Glass", "rain")
    bake(c.name, "rain")
    bpy.data.objects.remove(c)
    free("Glass", "rain")
    check(slots() == {"Glass": []}, f"slots {slots()}")
    assert bpy.ops.hydrobake.remove_deleted_bakes() == {"FINISHED"}
    clean()
elif case == "made_under_own_bake":  # 31: a pool without a material and two Alt+D copies;
    # one copy baked (the made material in the shared mesh's slot), the pool Shift+D copied
    # (its own mesh keeps that slot) and the copy baked on its own: freeing every bake, the
    # made material left the copy's mesh too, behind the copy's own material (monkey --more
    # --elsewhere 3783, --more --delete-baked 1539, 1587)
    w = pool()
    w1 = in_blender.duplicate(w, linked=True)
    w2 = in_blender.duplicate(w1, linked=True)
    bake("Water", "caustics")
    bake(w2.name, "caustics")
    free(w2.name, "caustics")
    bake(w1.name, "caustics")
    w4 = in_blender.duplicate(w)
    bake(w4.name, "caustics")
    for o in sorted(bpy.data.objects, key=lambda o: o.name):
        if o.hydrobake_caustics.is_baked:
            free(o.name, "caustics")
    left = [(m.name, m.users) for m in bpy.data.materials if m.name.startswith("HBK")]
    check(not left, f"made materials left {left} in slots {slots()}")
    clean()
elif case == "made_behind_copy_link":  # 32: a glass without a material baked (a made
    # material appended), Shift+D copied (its own mesh keeps it) with the copy's slot at
    # Link: Object, the copy baked, the glass deleted while baked and the copy freed: the
    # copy's mesh keeps the deleted glass's material behind the copy's own slot. A Shift+D
    # copy of the copy showing it (Link: Data) baked and freed: the first copy keeps its slot
    # at Link: Object, the second shows the mesh's material again (monkey --more
    # --delete-baked 1611: the bake wired the material the first copy held and its Free took
    # the first copy's slot away)
    g = glass(mat=None)
    bake("Glass", "rain")
    c = in_blender.duplicate(g)
    c.material_slots[0].link = "OBJECT"
    bake(c.name, "rain")
    bpy.data.objects.remove(g)
    free(c.name, "rain")
    d = in_blender.duplicate(c)
    d.material_slots[0].link = "DATA"
    def links(*objs):  # (a clean copy the Free leaves stands for the material it copied)
        return {o.name: [(s.link, s.material.get("hydrobake_copy_of", s.material.name)
                          if s.material else None) for s in o.material_slots] for o in objs}
    before = links(c, d)
    def images(m):
        return sorted(n.image.name for n in m.node_tree.nodes
                      if n.type == "TEX_IMAGE" and n.image is not None)
    held = images(c.data.materials[0])
    bake(d.name, "rain")
    check(images(c.data.materials[0]) == held,
          f"the copy's bake wired the material the first copy holds: {slots()}")
    free(d.name, "rain")
    check(links(c, d) == before, f"slots {links(c, d)}, were {before}")
    # The deleted glass's bake removed: its material goes, and the slot appended for it.
    check(bpy.ops.hydrobake.remove_deleted_bakes() == {"FINISHED"},
          "no deleted object's bake left to remove")
    check(links(c, d) == {c.name: [], d.name: []}, f"slots {links(c, d)}")
    clean()
elif case in ("linked_copy_deleted_baked", "linked_copy_deleted_floor_shared"):  # 33, 34:
    # a pool without a material and its Alt+D copy, both baked (the made material in the
    # mesh's slot, the copy's own copy of it at Link: Object); the pool freed keeps the
    # mesh's slot for the copy's Free, which never comes: the copy is deleted while baked.
    # The empty slot goes with it. 34: the pool shows the ground's floor material, and its
    # Free keeps its clean copy while the copy's floor nodes are in the shared one; the
    # delete takes them out and the pool shows the floor material again (monkey --more
    # --delete-baked 1620, both)
    shared = case == "linked_copy_deleted_floor_shared"
    w = pool()
    if shared:
        w.data.materials.append(bpy.data.materials["GroundMat"])
    w2 = in_blender.duplicate(w, linked=True)
    bake(w2.name, "caustics")
    bake("Water", "caustics")
    free("Water", "caustics")
    bpy.data.objects.remove(w2)
    bpy.context.view_layer.update()  # (as the UI evaluates after a delete)
    want = {"Ground": ["GroundMat"], "Water": ["GroundMat"] if shared else []}
    check(slots() == want and all(s.link == "DATA" for s in w.material_slots),
          f"slots {slots()}, Links {[s.link for s in w.material_slots]}")
    check("hydrobake_empty_slot" not in w.data, "the mesh keeps its empty-slot mark")
    check(bpy.ops.hydrobake.remove_deleted_bakes() == {"FINISHED"},
          "no deleted object's bake left to remove")
    clean()
elif case == "linked_copy_made_deleted":  # 35: an Alt+D copy of an object without a
    # material baked with snow (the made material in the shared mesh's slot, the object
    # showing it, the copy its own copy of it) and deleted while baked: removing the deleted
    # bake takes the made material too (monkey --more --delete-baked 1673)
    o = plane("Snowy", 0.5, (6, 0, 0))
    in_blender.snow(o, (1, 3), 40.0, 16)
    c = in_blender.duplicate(o, linked=True)
    bake(c.name, "snow")
    bpy.data.objects.remove(c)
    bpy.context.view_layer.update()
    check(bpy.ops.hydrobake.remove_deleted_bakes() == {"FINISHED"},
          "no deleted object's bake left to remove")
    check(slots() == {"Snowy": []}, f"slots {slots()}")
    clean()
elif case == "linked_copies_own_glass":  # 36: a pool without a material and its Alt+D
    # copy, both baked; the copy given the glass's material on its own slot (Link: Object),
    # the glass baked (its own copy of it), the copy Alt+D copied again and baked (its own
    # copy), the first copy renamed and baked (wiring the glass material itself). Freed in
    # turn, the mesh's empty slot stays for the copies' own materials, and its mark goes with
    # the last Free (monkey --more --elsewhere 3897)
    w = pool()
    w1 = in_blender.duplicate(w, linked=True)
    w1.name = "Water1"
    bake("Water1", "caustics")
    bake("Water", "caustics")
    w1.material_slots[0].material = in_blender.node_material("GlassMat")
    glass()
    bake("Glass", "rain")
    w2 = in_blender.duplicate(w1, linked=True)
    bake(w2.name, "caustics")
    w1.name = "Water1.A"
    bake("Water1.A", "caustics")
    for name, effect in (("Glass", "rain"), ("Water", "caustics"), (w2.name, "caustics"),
                         ("Water1.A", "caustics")):
        free(name, effect)
    links = {o.name: [(s.link, s.material.name if s.material else None)
                      for s in o.material_slots] for o in (w, w1, w2)}
    want = {"Water": [("DATA", None)], "Water1.A": [("OBJECT", "GlassMat")],
            w2.name: [("OBJECT", "GlassMat")]}
    check(links == want, f"slots {links}")
    check("hydrobake_empty_slot" not in w.data, "the mesh keeps its empty-slot mark")
    clean()
elif case in ("two_effects_one_shader", "two_effects_one_shader_lifo"):  # 37, 38: the
    # glass baked, its material given to a pool too, the glass re-baked (its own copy: the
    # material keeps the first bake's rain) and the pool baked (the material wired itself:
    # rain and the water both set the shader's Roughness, IOR and Transmission). Freed in
    # either order, the shader has its values from before both (monkey --more --elsewhere
    # 3897: the rain's Free put its values back under the water's, whose Free then put back
    # the rain's)
    glass()
    before = state(bpy.data.materials["GlassMat"])
    bake("Glass", "rain")
    w = pool()
    w.data.materials.append(bpy.data.materials["GlassMat"])
    bake("Glass", "rain")
    bake("Water", "caustics")
    check(tagged(bpy.data.materials["GlassMat"]) and
          {t.split(".")[0] for t in tagged(bpy.data.materials["GlassMat"])} ==
          {"rain", "caustics"}, f"GlassMat wired by {tagged(bpy.data.materials['GlassMat'])}")
    order = [("Glass", "rain"), ("Water", "caustics")]
    for name, effect in order if case == "two_effects_one_shader" else order[::-1]:
        free(name, effect)
    check(state(bpy.data.materials["GlassMat"]) == before,
          f"GlassMat {state(bpy.data.materials['GlassMat'])}, was {before}")
    clean()
elif case == "made_slot_removed_copy":  # 39: a pool without a material and its Alt+D
    # copy; the copy baked (the made material in the mesh's slot, the copy's own copy of it at
    # Link: Object), the pool Shift+D copied (its own mesh, showing the made one), the mesh's
    # slot removed: the copy's Free takes the made material out of the Shift+D copy, as it
    # would have with the slot in place (monkey --more --delete-baked --elsewhere 7176)
    w = pool()
    w2 = in_blender.duplicate(w, linked=True)
    bake(w2.name, "caustics")
    w3 = in_blender.duplicate(w)
    w.active_material_index = 0
    with bpy.context.temp_override(object=w):
        bpy.ops.object.material_slot_remove()
    free(w2.name, "caustics")
    check(slots() == {"Ground": ["GroundMat"], "Water": [], w2.name: [], w3.name: []},
          f"slots {slots()}")
    clean()
elif case == "linked_copy_own_made_deleted":  # 40: an object without a material baked
    # with snow and Alt+D copied (the copy keeps the record), renamed and freed, baked again
    # (the made material in the mesh's slot, the object's own copy of it at Link: Object),
    # the copy re-baked (its made one in the mesh's slot now) and deleted while baked:
    # removing its bake takes its made material out of the mesh, and the object's Free
    # leaves no slot (monkey --more --delete-baked --elsewhere 7147)
    o = plane("Snowy", 0.5, (6, 0, 0))
    in_blender.snow(o, (1, 3), 40.0, 16)
    bake("Snowy", "snow")
    c = in_blender.duplicate(o, linked=True)
    o.name = "Snow2"
    free("Snow2", "snow")
    bake("Snow2", "snow")
    bake(c.name, "snow")
    bpy.data.objects.remove(c)
    bpy.context.view_layer.update()
    check(bpy.ops.hydrobake.remove_deleted_bakes() == {"FINISHED"},
          "no deleted object's bake left to remove")
    free("Snow2", "snow")
    check(slots() == {"Snow2": []}, f"slots {slots()}")
    check("hydrobake_empty_slot" not in o.data, "the mesh keeps its empty-slot mark")
    clean()
elif case == "made_slot_removed_copy_marked":  # 41: a pool without a material and two
    # Alt+D copies; one copy baked and its slot removed, the other baked (a made material
    # appended, its own copy of it), the first freed (the mesh's slot stays, empty, marked
    # for the other's own material) and baked again (its made material fills the slot); the
    # other Shift+D copied (the mark goes with the mesh) and the copy freed; the slot removed
    # again: Free All leaves the Shift+D copy no slot either (monkey --more --delete-baked
    # --elsewhere 7176)
    w = pool()
    a = in_blender.duplicate(w, linked=True)
    b = in_blender.duplicate(w, linked=True)

    def remove_slot(o):
        o.active_material_index = 0
        with bpy.context.temp_override(object=o):
            bpy.ops.object.material_slot_remove()
    bake(a.name, "caustics")
    remove_slot(w)
    bake(b.name, "caustics")
    free(a.name, "caustics")
    bake(a.name, "caustics")
    c = in_blender.duplicate(b)
    free(c.name, "caustics")
    remove_slot(b)
    for o in (b, a):  # (Free All's order there)
        free(o.name, "caustics")
    check(slots() == {"Ground": ["GroundMat"], "Water": [], a.name: [], b.name: [],
                      c.name: []}, f"slots {slots()}")
    check("hydrobake_empty_slot" not in c.data, "the copy's mesh keeps the empty-slot mark")
    clean()
elif case in ("linked_copy_slot_removed", "linked_copy_slot_removed_copied",
              "linked_copy_slot_removed_then_copied"):  # 42, 43, 46: a glass of two materials and its Alt+D
    # copy; the copy baked (its own copies of both at Link: Object), the second slot removed
    # through the glass: Blender 3.4 keeps the copy's own material of the gone slot past its
    # slots, and the Free removing that copy (used by nothing) left it pointing at freed
    # memory, which a slot added to the copy then showed: a segfault (monkey --more
    # --delete-baked --elsewhere 7215). 43: the baked copy Shift+D copied before, whose Free
    # (first, by name) removes the copy it shows too. 46: the baked copy Shift+D copied after
    # the slot went, and that copy baked on its own: Blender copies the list past the slots
    # too, so the copy's pointed at the material the first Free removed, and a slot added to
    # it showed freed memory (every flag + --relations 144: a segfault)
    g = glass()
    g.data.materials.append(in_blender.node_material("FritMat"))
    c = in_blender.duplicate(g, linked=True)
    bake(c.name, "rain")
    check([s.link for s in c.material_slots] == ["OBJECT", "OBJECT"],
          f"the copy's links {[s.link for s in c.material_slots]}")
    d = in_blender.duplicate(c) if case.endswith("removed_copied") else None
    g.active_material_index = 1
    with bpy.context.temp_override(object=g):
        bpy.ops.object.material_slot_remove()
    if d is not None:
        d.name = "Frit first"
        free(d.name, "rain")
    e = in_blender.duplicate(c) if case.endswith("then_copied") else None
    if e is not None:
        e.name = "Frit copied"
        bake(e.name, "rain")  # a bake of its own: c's Free is not its Free
    free(c.name, "rain")
    dangling = in_blender.dangling_materials()
    check(not dangling, f"objects pointing at removed materials {dangling}")
    if e is not None:
        free(e.name, "rain")
    for o in (c, e) if e is not None else (c,):
        o.active_material_index = 0
        with bpy.context.temp_override(object=o):
            bpy.ops.object.material_slot_add()
    want = {"Glass": ["GlassMat", None], c.name: ["GlassMat", None]}
    if d is not None:
        want[d.name] = ["GlassMat", "FritMat"]
    if e is not None:
        want[e.name] = ["GlassMat", None]
    check(slots() == want, f"slots {slots()}")
    check([s.link for s in c.material_slots] == ["DATA", "DATA"],
          f"the copy's links {[s.link for s in c.material_slots]}")
    clean()
elif case == "linked_copy_own_slots_kept":  # 44: what the Free's clearing of the copy's
    # own-material list past its slots (cases 42, 43) must keep: the artist's own materials
    # shown and behind the mesh's, their users, the Links, the active slot, the shape keys.
    # The bake's copy went over the one behind (a save then dropped it, used by nothing): it
    # is held meanwhile, and put back
    g = glass()
    for name in ("FritMat", "TintMat"):
        g.data.materials.append(in_blender.node_material(name))
    c = in_blender.duplicate(g, linked=True)
    own, behind = in_blender.node_material("Own"), in_blender.node_material("Behind")
    c.material_slots[2].link = "OBJECT"
    c.material_slots[2].material = own
    c.material_slots[1].link = "OBJECT"
    c.material_slots[1].material = behind
    c.material_slots[1].link = "DATA"
    c.shape_key_add(name="Basis")
    c.shape_key_add(name="Up")
    c.active_shape_key_index = 1
    bake(c.name, "rain")
    check(behind.users == 1, f"the own material behind the mesh's has {behind.users} users "
          "while baked")
    c.active_material_index = 2
    free(c.name, "rain")
    check([s.link for s in c.material_slots] == ["DATA", "DATA", "OBJECT"],
          f"the copy's links {[s.link for s in c.material_slots]}")
    check(slots()[c.name] == ["GlassMat", "FritMat", "Own"], f"slots {slots()}")
    c.material_slots[1].link = "OBJECT"
    check(c.material_slots[1].material == behind, "the own material behind the mesh's is gone")
    c.material_slots[1].link = "DATA"
    check((own.users, behind.users) == (1, 1), f"users {own.users}, {behind.users}")
    check(c.active_material_index == 2 and c.active_shape_key_index == 1,
          f"active slot {c.active_material_index}, shape key {c.active_shape_key_index}")
    check(c.data == g.data and not any(m.name.startswith("HBK empty") for m in bpy.data.meshes),
          f"meshes {[m.name for m in bpy.data.meshes]}")
    clean()
elif case == "copy_name_taken":  # 45: the artist's material named as a bake's copy would
    g = glass()                      # be ('<shared> (<object>)') keeps its name
    c = in_blender.duplicate(g)
    taken = in_blender.node_material(f"GlassMat ({c.name})")
    g.data.materials.append(taken)
    bake(c.name, "rain")
    check(taken.name == f"GlassMat ({c.name})", f"the artist's material renamed {taken.name!r}")
    check(c.material_slots[0].material.get("hydrobake_copy_of") == "GlassMat",
          f"the copy's slot shows {c.material_slots[0].material.name}")
    free(c.name, "rain")
    check(slots() == {"Glass": ["GlassMat", f"GlassMat ({c.name})"], c.name: ["GlassMat"]},
          f"slots {slots()}")
    clean()
elif case == "linked_copy_in_mesh_slot":  # 47: a glass and its Alt+D copy; the copy baked
    # (its own copy at Link: Object), then the artist gives the mesh's slot that copy too.
    # The copy's Free switched the slot back to the mesh's, found the same copy there, put
    # the material back in that call and removed the copy, then read the removed copy: a
    # ReferenceError, the Free undone (every flag + --scene --external --relations 711)
    g = glass()
    c = in_blender.duplicate(g, linked=True)
    bake(c.name, "rain")
    mine = c.material_slots[0].material
    check(mine.name == f"GlassMat ({c.name})", f"the copy's slot shows {mine.name}")
    g.material_slots[0].material = mine  # (Link: Data, so the mesh's)
    free(c.name, "rain")
    check(slots() == {"Glass": ["GlassMat"], c.name: ["GlassMat"]}, f"slots {slots()}")
    check([s.link for s in c.material_slots] == ["DATA"],
          f"the copy's links {[s.link for s in c.material_slots]}")
    check(not c.hydrobake_rain.is_baked, "the copy is still baked")
    clean()
elif case == "made_copy_dropped":  # 48: a pool and its Alt+D copy; the pool baked (the
    # material made for the mesh, the pool's own copy holding the wiring), then the artist
    # gives the pool's slot another material: a save drops the copy, the one record that the
    # made material goes with the pool's Free. It stayed in the mesh's slot, shown by the
    # Alt+D copy, with nothing baked (every flag + --scene --external 950)
    pool()
    in_blender.duplicate(bpy.data.objects["Water"], linked=True)
    bake("Water", "caustics")
    w = bpy.data.objects["Water"]
    check(slots()["Water"] == ["HBK_Water_water (Water)"], f"slots {slots()}")
    w.material_slots[0].material = in_blender.node_material("UserMat")  # (Link: Object)
    bpy.ops.wm.save_mainfile()
    bpy.ops.wm.open_mainfile(filepath=bpy.data.filepath)
    check("HBK_Water_water (Water)" not in bpy.data.materials, "the copy was saved")
    check(slots()["Water.001"] == ["HBK_Water_water"],  # (the pool's Free's, not the load's)
          f"the Alt+D copy's slot after the load: {slots()}")
    c = in_blender.duplicate(bpy.data.objects["Water"])  # Shift+D: holds the bake too
    check(c.hydrobake_caustics.is_baked, "the Shift+D copy holds no bake")
    free("Water", "caustics")
    check(slots()["Water.001"] == [None], f"the Alt+D copy's slot: {slots()}")
    check(list(c.data.materials) == [bpy.data.materials.get("HBK_Water_water")],
          f"the Shift+D copy's mesh: {list(c.data.materials)}")  # (its bake's own Free)
    free(c.name, "caustics")
    check(slots() == {"Ground": ["GroundMat"], "Water": ["UserMat"], "Water.001": [None],
                      c.name: ["UserMat"]}, f"slots {slots()}")  # (its own slot)
    clean()
elif case == "linked_copy_given_own_slot":  # 49: a glass and its Alt+D copy; the glass
    # baked (its own copy at Link: Object, recording the mesh's Link), then the artist gives
    # that copy to another object's own slot. The glass's Free switched that object's slot to
    # its mesh's material too, which the copy's record was not about (every flag + --scene 816)
    g = glass()
    in_blender.duplicate(g, linked=True)
    h = glass("Pane", "PaneMat", (5, 0, 1))
    bake("Glass", "rain")
    mine = g.material_slots[0].material
    check(mine.name == "GlassMat (Glass)", f"the glass's slot shows {mine.name}")
    h.material_slots[0].link = "OBJECT"
    h.material_slots[0].material = mine
    free("Glass", "rain")
    check(slots() == {"Glass": ["GlassMat"], "Glass.001": ["GlassMat"], "Pane": ["GlassMat"]},
          f"slots {slots()}")
    check([s.link for s in h.material_slots] == ["OBJECT"],
          f"the pane's links {[s.link for s in h.material_slots]}")
    clean()
elif case in ("made_deleted_dropped", "made_deleted_dropped_own_mesh"):  # 50, 51: a pool
    # and its Alt+D copy; the pool baked (the material made for the mesh, the pool's own copy
    # holding the wiring), given a mesh of its own (Make Single User: 51) or not, then
    # deleted, and the file saved and opened: the save dropped the copy, the one record of
    # the bake, and the made material stayed in the Alt+D copy's slot with nothing to take
    # it out (every flag + --relations 159)
    pool()
    copy = in_blender.duplicate(bpy.data.objects["Water"], linked=True)
    bake("Water", "caustics")
    w = bpy.data.objects["Water"]
    if case.endswith("own_mesh"):
        in_blender.select_alone(w)
        assert bpy.ops.object.make_single_user(type="SELECTED_OBJECTS", object=True,
                                               obdata=True) == {"FINISHED"}
    check(slots()[copy.name] == ["HBK_Water_water"], f"slots {slots()}")
    in_blender.select_alone(w)
    assert bpy.ops.object.delete() == {"FINISHED"}
    bpy.context.view_layer.update()
    in_blender.reopen()
    check("HBK_Water_water (Water)" not in bpy.data.materials, "the copy was saved")
    check(slots() == {"Ground": ["GroundMat"], "Water.001": []}, f"slots {slots()}")
    clean()
elif case == "made_slot_tidied_copies":  # 52: a pool with two slots, its first empty, baked
    # (the material made for that slot), two Shift+D copies after (each holding the bake),
    # the pool and the second copy freed (the made material stays for the first copy's Free),
    # then the first copy's slots tidied (Remove Unused Slots took the made one's slot). The
    # last Free left it in the second copy's slot (every flag + --scene --external 984)
    w = pool()
    w.data.materials.append(None)
    w.data.materials.append(None)
    w.material_slots[1].link = "OBJECT"
    for face in w.data.polygons:  # (the faces use the second slot: the first is unused)
        face.material_index = 1
    bake("Water", "caustics")
    check(slots()["Water"] == ["HBK_Water_water", None], f"slots {slots()}")
    a = in_blender.duplicate(w)
    free("Water", "caustics")
    b = in_blender.duplicate(a)
    free(b.name, "caustics")
    check(slots()[b.name] == ["HBK_Water_water", None], f"slots {slots()}")  # (a holds it)
    in_blender.select_alone(a)
    bpy.ops.object.material_slot_remove_unused()
    check("HBK_Water_water" not in slots()[a.name], f"slots {slots()}")
    free(a.name, "caustics")
    check(all("HBK_Water_water" not in v for v in slots().values()), f"slots {slots()}")
    clean()
elif case == "linked_copy_shows_deleted":  # 53: an Alt+D copy of a pool whose mesh's slot
    # shows the material a snow bake made for an object deleted while baked (its wiring stays
    # until Remove Deleted Objects' Bakes). The copy's bake copies it at Link: Object, the
    # snow's nodes along; its Free kept that copy, as if the snow were the copy's own bake,
    # instead of showing the mesh's slot again (every flag + --scene --external
    # --relations 756)
    s = plane("Snowy", 0.5, (-3, 0, 0))
    in_blender.snow(s, (1, 3), 40.0, 16)
    bake("Snowy", "snow")
    made = s.material_slots[0].material
    w = pool()
    w.data.materials.append(made)
    w2 = in_blender.duplicate(w, linked=True)
    bpy.data.objects.remove(s)
    bpy.context.view_layer.update()
    bake(w2.name, "caustics")
    check(w2.material_slots[0].link == "OBJECT", "the bake went into the mesh's slot")
    free(w2.name, "caustics")
    want = {"Ground": ["GroundMat"], "Water": [made.name], w2.name: [made.name]}
    check(slots() == want and all(s.link == "DATA" for s in w2.material_slots),
          f"slots {slots()}, Links {[s.link for s in w2.material_slots]}")
    check(not any("hydrobake_copy_of" in m for m in bpy.data.materials),
          f"a copy left: {[m.name for m in bpy.data.materials]}")
    check(bpy.ops.hydrobake.remove_deleted_bakes() == {"FINISHED"}, "no deleted bake to remove")
    check(slots() == {"Ground": ["GroundMat"], "Water": [], w2.name: []}, f"then slots {slots()}")
    clean()
elif case == "refilled_slot_of_deleted":  # 54: three Alt+D copies of one mesh whose slot
    # a made material left, kept and marked (as a Free leaves it while an object of the mesh
    # shows a copy there: the monkey's path to it is long); one baked (its made material fills
    # the slot) and deleted while baked, another showing nothing of its own at Link: Object:
    # deleting the third, unbaked, dropped the slot with the deleted object's material in it
    # before Remove Deleted Objects' Bakes, the second's slot with it (every flag + --scene 2137)
    o = plane("Snowy", 0.5, (6, 0, 0))
    o.data.materials.append(None)
    o.data["hydrobake_empty_slot"] = 0
    c, d = (in_blender.duplicate(o, linked=True) for _ in range(2))
    o.material_slots[0].link = "OBJECT"
    in_blender.snow(d, (1, 1), 40.0, 16)
    bake(d.name, "snow")
    kept = o.data.materials[0]
    check(kept is not None and kept.get("hydrobake_made") == "appended", f"slots {slots()}")
    bpy.data.objects.remove(d)
    bpy.context.view_layer.update()
    bpy.data.objects.remove(c)
    bpy.context.view_layer.update()
    check(len(o.material_slots) == 1 and o.data.materials[0] == kept,
          f"the deleted object's made material left before its removal: {slots()}")
    check(bpy.ops.hydrobake.remove_deleted_bakes() == {"FINISHED"}, "no deleted bake to remove")
    check(slots() == {"Snowy": []}, f"then slots {slots()}")
    check("hydrobake_empty_slot" not in o.data, "the mesh keeps its empty-slot mark")
    clean()
else:
    raise SystemExit(f"no case {case}")
print(f"FREE RESTORES {case} " + ("OK" if not problems else "FAIL " + "; ".join(problems)))
