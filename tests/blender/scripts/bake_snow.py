"""The snow effect through the real addon on examples.blend: bake the person briefly, check
that skin takes no snow while the coat does, the wiring into the materials, and Free Bake."""
import json
import os

import bpy
import numpy as np

import in_blender

in_blender.enable()
from hydrobake.core import exr  # noqa: E402
from hydrobake.core.bake.cache import frame_path  # noqa: E402

tmp = in_blender.args()[0]
bpy.ops.wm.save_as_mainfile(filepath=os.path.join(tmp, "snow.blend"))
scene = bpy.data.scenes["Snow"]
person = bpy.data.objects["Person"]
s = person.hydrobake_snow
s.use_scene_range = False
s.frame_start, s.frame_end = 1, 4
s.flake_density = 3000.0  # about 200 000 flakes
s.snow.texture_width = s.snow.texture_height = 256
s.write_flakes = True
with bpy.context.temp_override(scene=scene):
    assert bpy.ops.hydrobake.bake(effect="snow", object_name="Person") == {"FINISHED"}
cov = exr.read(frame_path(s.bake_folder, "coverage", 4, "exr"))["A"]
# Per material: coverage inside each part's UV cell (parts are packed 3x3 in UV space).
mesh = person.data
uv = np.array([d.uv[:] for d in mesh.uv_layers.active.data])
amount = {}
for poly in mesh.polygons:
    name = person.material_slots[poly.material_index].material.name
    us = uv[list(poly.loop_indices)]
    lo, hi = (us.min(axis=0) * 256).astype(int), (us.max(axis=0) * 256).astype(int) + 1
    amount.setdefault(name, []).append(float(cov[lo[1]:hi[1], lo[0]:hi[0]].sum()))
amount = {k: sum(v) for k, v in amount.items()}
assert amount["Skin"] == 0.0, amount  # warm skin melts every flake
assert amount["Coat"] > 0.0, amount
print("coverage per material", amount)

coat = bpy.data.materials["Coat"].node_tree
out = next(n for n in coat.nodes if n.type == "OUTPUT_MATERIAL")
assert out.inputs["Surface"].links[0].from_node.get("hydrobake") == "snow.mix"
skin = bpy.data.materials["Skin"].node_tree
assert not any(n.get("hydrobake") for n in skin.nodes)

# The falling flakes as points that follow the frame, instanced by Geometry Nodes.
flakes = bpy.data.objects["HBK_Person_flakes"]
scene.frame_set(4)
# Flake Density x the Auto Volume fitted around the person (about 66 m³).
with open(os.path.join(s.bake_folder, "manifest.json")) as f:
    sp = json.load(f)["params"]["snow"]
volume = np.prod(np.subtract(sp["volume_max"], sp["volume_min"]))
assert 60 < volume < 80, volume
assert sp["flake_count"] == round(3000.0 * volume), (sp["flake_count"], volume)
assert len(flakes.data.vertices) == sp["flake_count"]
z4 = flakes.data.vertices[0].co.z
scene.frame_set(2)
assert flakes.data.vertices[0].co.z != z4
assert flakes.modifiers["HBK Instances"].node_group is not None

assert bpy.ops.hydrobake.free_bake(effect="snow", object_name="Person") == {"FINISHED"}
assert "HBK_Person_flakes" not in bpy.data.objects
# Its instancer and the flakes' material went with it (nothing else used them).
assert not [g.name for g in bpy.data.node_groups if g.name.startswith("HBK Flake")]
assert "HBK Snow Flake" not in bpy.data.materials
assert out.inputs["Surface"].links[0].from_node.type == "BSDF_PRINCIPLED"
assert not any(n.get("hydrobake") for n in coat.nodes)
print("SNOW BLENDER OK")
