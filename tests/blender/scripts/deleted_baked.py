"""Snow and rain objects deleted while baked (no Free Bake first): their wiring leaves the
materials they showed (reused later, or shown by other objects), which are as before the
bake; their own material copies, flakes and images go; their files stay, as any deleted
object's. A Shift+D copy holding the same bake keeps it. (Monkey seed 159.)"""
import os

import bpy

import in_blender

in_blender.enable()
from hydrobake.blender.bridge import materials  # noqa: E402

tmp = in_blender.empty_file("deleted_baked.blend")


def tagged(mat):
    return sorted(str(n.get(materials.TAG)) for n in mat.node_tree.nodes
                  if n.get(materials.TAG)) if mat.node_tree else []


def state(mat):
    return (mat.use_nodes, sorted(n.name for n in mat.node_tree.nodes) if mat.node_tree else
            None, len(mat.node_tree.links) if mat.node_tree else 0,
            sorted(k for k in mat.keys() if k.startswith("hydrobake") and k != "hydrobake_snow"))


def bake(name, effect):
    assert bpy.ops.hydrobake.bake(effect=effect, object_name=name) == {"FINISHED"}
    obj = bpy.data.objects[name]
    return bpy.path.abspath(getattr(obj, f"hydrobake_{effect}").bake_folder)


def delete(name):
    bpy.data.objects.remove(bpy.data.objects[name])
    bpy.context.view_layer.update()  # what the UI does after a delete


def glass(name, mat):
    o = in_blender.uv_plane(name)
    o.location.x = 3 * len(bpy.data.objects)
    if mat is not None:
        o.data.materials.append(mat)
    s = o.hydrobake_rain
    s.enabled, s.rain.cell_size = True, 0.05
    s.use_scene_range, s.frame_start, s.frame_end = False, 1, 2
    return o


# Snow in its object's own material, whose nodes were off: the material, reusable, is as
# before; the flakes and the images go.
felt = bpy.data.materials.new("Felt")
snowy = in_blender.uv_plane("Snowy")
snowy.data.materials.append(felt)
in_blender.snow(snowy, (1, 2), 40.0, 16).write_flakes = True
before = state(felt)
folder = bake("Snowy", "snow")
assert tagged(felt) and "HBK_Snowy_flakes" in bpy.data.objects
delete("Snowy")
assert not tagged(felt), f"the deleted object's snow stayed in Felt: {tagged(felt)}"
# (Nodes once on stay in the file while off, as after a Free Bake.)
assert state(felt)[::3] == before[::3], f"Felt is {state(felt)}, was {before}"
assert "HBK_Snowy_flakes" not in bpy.data.objects
assert not [i.name for i in bpy.data.images if i.name.startswith("HBK_Snowy")]
assert os.path.isfile(os.path.join(folder, "manifest.json")), "the deleted object's files went"

# Rain on a glass sharing its material with a pane: the glass's own copy goes, the shared
# material was never wired.
shared = in_blender.node_material("GlassMat")
before = state(shared)
glass("Glass", shared)
glass("Pane", shared)
bake("Glass", "rain")
assert tagged(bpy.data.materials["GlassMat (Glass)"]) and not tagged(shared)
delete("Glass")
assert "GlassMat (Glass)" not in bpy.data.materials, "the deleted glass's copy stayed"
assert state(shared) == before and [s.material for s in bpy.data.objects["Pane"].material_slots] \
    == [shared]

# A glass with no material (the bake made one), Shift+D copied, the original deleted: the
# copy holds the bake's record and still shows it; its Free takes everything.
g = glass("Screen", None)
bake("Screen", "rain")
copy = in_blender.duplicate(g)
delete("Screen")
made = bpy.data.materials["HBK_Screen_glass"]
assert tagged(made) and copy.hydrobake_rain.is_baked, "the copy's bake went with the original"
bpy.ops.wm.save_mainfile()  # the save forgets nothing held either
assert tagged(bpy.data.materials["HBK_Screen_glass"])
assert bpy.ops.hydrobake.free_bake(effect="rain", object_name=copy.name) == {"FINISHED"}
assert "HBK_Screen_glass" not in bpy.data.materials
assert not [m.name for m in bpy.data.materials if tagged(m)]
print("DELETED BAKED OK")
