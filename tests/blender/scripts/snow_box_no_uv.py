"""BOX mode makes its own atlas coordinates (HBK_SnowBox), so it bakes a mesh without a UV
map; TRIANGLES mode still refuses it, naming the way out."""
import os

import bpy

import in_blender

in_blender.enable()

tmp = in_blender.args()[0]
bpy.ops.wm.save_as_mainfile(filepath=os.path.join(tmp, "box_no_uv.blend"))
cube = bpy.data.objects["Cube"]
mesh = cube.data
mesh.uv_layers.remove(mesh.uv_layers[0])
s = in_blender.snow(cube, (1, 2), 200, 64)
try:
    bpy.ops.hydrobake.bake(effect="snow", object_name="Cube")
except RuntimeError as exc:
    assert "needs a UV map" in str(exc) and "BOX" in str(exc), exc
else:
    raise AssertionError("TRIANGLES mode baked a mesh without a UV map")
s.snow.contact_mode = "BOX"
assert bpy.ops.hydrobake.bake(effect="snow", object_name="Cube") == {"FINISHED"}
ev = cube.evaluated_get(bpy.context.evaluated_depsgraph_get()).to_mesh()
assert "HBK_SnowBox" in ev.attributes
tree = bpy.data.materials["Material"].node_tree
uvn = next(n for n in tree.nodes if n.get("hydrobake") == "snow.uv")
assert uvn.attribute_name == "HBK_SnowBox"
assert bpy.ops.hydrobake.free_bake(effect="snow", object_name="Cube") == {"FINISHED"}
assert len(mesh.uv_layers) == 0 and len(cube.modifiers) == 0
print("SNOW BOX NO UV OK")
