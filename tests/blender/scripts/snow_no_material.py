"""Snow on an object without a material gets a new node material, and on a material with its
nodes off turns them on; Free Bake gives both back (the new material goes, the nodes are off
again). A second bake over the first gives the same snow: the made material catches what
the empty slot did."""
import json
import os

import bpy

import in_blender

in_blender.enable()

tmp = in_blender.args()[0]
bpy.ops.wm.save_as_mainfile(filepath=os.path.join(tmp, "nomat.blend"))
cube = bpy.data.objects["Cube"]
cube.data.materials.clear()  # no material at all
bpy.ops.mesh.primitive_cube_add(location=(4, 0, 0))
old = bpy.context.object
old.name = "OldCube"
old.data.materials.append(bpy.data.materials.new("NoNodes"))  # nodes off


def frames_of(s):
    with open(os.path.join(s.bake_folder, "manifest.json")) as f:
        return json.load(f)["frames"]


def snow_output(mat):
    out = next(n for n in mat.node_tree.nodes if n.type == "OUTPUT_MATERIAL" and
               n.is_active_output)
    return out.inputs["Surface"].links[0].from_node.get("hydrobake")


for o in (cube, old):
    s = in_blender.snow(o, (1, 2), 200, 64)
    assert bpy.ops.hydrobake.bake(effect="snow", object_name=o.name) == {"FINISHED"}
    first = frames_of(s)
    mat = o.material_slots[0].material if o.material_slots else None
    assert mat is not None and mat.use_nodes, o.name
    assert snow_output(mat) == "snow.mix", o.name
    assert bpy.ops.hydrobake.bake(effect="snow", object_name=o.name) == {"FINISHED"}
    assert frames_of(s) == first, o.name
    assert snow_output(mat) == "snow.mix", o.name

assert cube.material_slots[0].material.name == "HBK_Cube_snow"
assert bpy.ops.hydrobake.free_bake(effect="snow", object_name="Cube") == {"FINISHED"}
assert len(cube.data.materials) == 0, list(cube.data.materials)
assert "HBK_Cube_snow" not in bpy.data.materials
nonodes = bpy.data.materials["NoNodes"]
assert bpy.ops.hydrobake.free_bake(effect="snow", object_name="OldCube") == {"FINISHED"}
assert old.material_slots[0].material == nonodes
assert not nonodes.use_nodes and "hydrobake_nodes_were_off" not in nonodes
assert not any(n.get("hydrobake") for n in nonodes.node_tree.nodes)
print("SNOW NO MATERIAL OK")
