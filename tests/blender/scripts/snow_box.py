"""The paper's BOX contact mode through the addon: the atlas (a block of six tiles per material
slot) is projected back onto the model by a Geometry Nodes modifier, whose face corner
attribute HBK_SnowBox the materials read."""
import os

import bpy
import numpy as np

import in_blender

in_blender.enable()
from hydrobake.core import exr  # noqa: E402
from hydrobake.core.bake.cache import frame_path  # noqa: E402

tmp = in_blender.args()[0]
bpy.ops.wm.save_as_mainfile(filepath=os.path.join(tmp, "box.blend"))
scene = bpy.data.scenes["Snow"]
person = bpy.data.objects["Person"]
s = person.hydrobake_snow
s.use_scene_range, s.frame_start, s.frame_end = False, 1, 3
s.snow.contact_mode = "BOX"
s.flake_density = 3000.0  # about 200 000 flakes
s.snow.texture_width = s.snow.texture_height = 96
with bpy.context.temp_override(scene=scene):
    assert bpy.ops.hydrobake.bake(effect="snow", object_name="Person") == {"FINISHED"}
cov = exr.read(frame_path(s.bake_folder, "coverage", 3, "exr"))["A"]
assert cov.shape == (96 * 4, 96), cov.shape  # one block per material slot
assert person.modifiers[-1].name == "HBK Snow Box"
with bpy.context.temp_override(scene=scene):  # the Snow scene's evaluated person
    mesh = person.evaluated_get(bpy.context.evaluated_depsgraph_get()).to_mesh()
uv = np.empty(len(mesh.loops) * 3, np.float32)
mesh.attributes["HBK_SnowBox"].data.foreach_get("vector", uv)
uv = uv.reshape(-1, 3)[:, :2]
# Coverage seen through the generated coordinates, per material: the coat (slot 1) catches
# snow on its top, the skin (slot 0) melts everything.
got = {}
for p in mesh.polygons:
    us = uv[list(p.loop_indices)]
    c = us.mean(axis=0)
    val = cov[min(int(c[1] * cov.shape[0]), cov.shape[0] - 1), min(int(c[0] * 96), 95)]
    got.setdefault(p.material_index, []).append(val)
assert max(got[0]) == 0.0 and max(got[1]) > 0.0, {k: max(v) for k, v in got.items()}
coat = bpy.data.materials["Coat"].node_tree
uvn = next(n for n in coat.nodes if n.get("hydrobake") == "snow.uv")
assert uvn.type == "ATTRIBUTE" and uvn.attribute_name == "HBK_SnowBox"
assert bpy.ops.hydrobake.free_bake(effect="snow", object_name="Person") == {"FINISHED"}
assert "HBK Snow Box" not in person.modifiers
assert "HBK_Person_SnowBox" not in bpy.data.node_groups
assert "HBK_SnowBox" not in person.data.uv_layers
print("SNOW BOX OK")
