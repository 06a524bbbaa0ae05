"""Windshield rain through the real addon on examples.blend: the grid comes from the curved
glass's UV layout, the bake wires tangent-space normals into the glass material, Free undoes it."""
import json
import os

import bpy

import in_blender

in_blender.enable()
from hydrobake.core import exr  # noqa: E402
from hydrobake.core.bake.cache import frame_path  # noqa: E402

tmp = in_blender.args()[0]
bpy.ops.wm.save_as_mainfile(filepath=os.path.join(tmp, "rain.blend"))
scene = bpy.data.scenes["Rain"]
glass = bpy.data.objects["Windshield"]
s = glass.hydrobake_rain
before = [m.name if m else None for m in glass.data.materials]  # as Free must leave them
s.use_scene_range, s.frame_start, s.frame_end = False, 1, 3
s.rain.cell_size = 0.01  # a coarse grid for the test
assert s.wiper_0 is not None and s.wiper_1 is not None  # the example's blades are animated
bg = bpy.data.images.new("street", 64, 32)
s.background_image = bg
with bpy.context.temp_override(scene=scene):
    assert bpy.ops.hydrobake.bake(effect="rain", object_name="Windshield") == {"FINISHED"}
m = json.load(open(os.path.join(s.bake_folder, "manifest.json")))
p = m["params"]["rain"]
# The glass is 1.4 m across and about 0.75 m up its (curved) surface: 1 cm cells.
assert 138 <= p["width"] <= 146 and 73 <= p["height"] <= 80, (p["width"], p["height"])
assert p["map_width"] == 2 * p["width"]
data = exr.read(frame_path(s.bake_folder, "rain", 3, "exr"))
assert set(data) == {"height", "normal.x", "normal.y", "normal.z", "wetness"}
assert data["height"].max() > 0  # drops landed and were drawn
assert os.path.isfile(frame_path(s.bake_folder, "preview", 3, "exr"))  # cheap refraction
assert bpy.data.images["HBK_Windshield_rain_preview"].source == "SEQUENCE"
assert bpy.data.images["HBK_Windshield_rain_preview"].use_fake_user  # kept when saved

tree = glass.data.materials[0].node_tree
bsdf = next(n for n in tree.nodes if n.type == "BSDF_PRINCIPLED")
assert bsdf.inputs["Transmission"].default_value == 1.0
assert abs(bsdf.inputs["IOR"].default_value - 1.33) < 1e-6
# Drop normals on the faces rays leave by, the flat normal on those they enter by.
side = bsdf.inputs["Normal"].links[0].from_node
assert side.get("hydrobake") == "rain.side"
assert side.inputs["Fac"].links[0].from_socket.name == "Backfacing"
assert side.inputs["Color1"].links[0].from_node.type == "NEW_GEOMETRY"
nm = side.inputs["Color2"].links[0].from_node
assert nm.get("hydrobake") == "rain.normalmap" and nm.space == "TANGENT"
out = next(n for n in tree.nodes if n.type == "OUTPUT_MATERIAL")
assert out.inputs["Surface"].links[0].from_node == bsdf
mod = next(m for m in glass.modifiers if m.type == "SOLIDIFY")  # two faces: a lens
assert 0.001 <= mod.thickness <= 0.01
# A re-bake grids the glass's own surface, not the two faces of the thickness.
with bpy.context.temp_override(scene=scene):
    assert bpy.ops.hydrobake.free_bake(effect="rain", object_name="Windshield") == {"FINISHED"}
    glass.modifiers.new("User Thickness", "SOLIDIFY").thickness = 0.006
    assert bpy.ops.hydrobake.bake(effect="rain", object_name="Windshield") == {"FINISHED"}
m2 = json.load(open(os.path.join(s.bake_folder, "manifest.json")))
assert m2["params"]["rain"]["width"] == p["width"], (m2["params"]["rain"]["width"], p["width"])
assert [m.name for m in glass.modifiers] == ["User Thickness"]  # theirs is kept, none added
assert all(m.show_viewport for m in glass.modifiers)

tree = glass.data.materials[0].node_tree
assert bpy.ops.hydrobake.free_bake(effect="rain", object_name="Windshield") == {"FINISHED"}
assert [m.name if m else None for m in glass.data.materials] == before, before
for mat in glass.data.materials:
    assert mat is None or not any(n.get("hydrobake") for n in mat.node_tree.nodes)
assert [m.name for m in glass.modifiers] == ["User Thickness"]
assert "HBK_Windshield_rain_preview" not in bpy.data.images

# Grid From Mesh with cells too fine for memory: refused naming Cell Size and what would do,
# before anything is baked (1.4 x 0.75 m in 0.1 mm cells is 14000 x 7500).
s.rain.cell_size = 1e-4
with bpy.context.temp_override(scene=scene):
    try:
        bpy.ops.hydrobake.bake(effect="rain", object_name="Windshield")
        raise AssertionError("a 14000 x 7500 glass was not refused")
    except RuntimeError as exc:
        msg = str(exc)
assert "Cell Size = 0.0001 m: gives 1" in msg and "16777216 allowed; use at least 0.00025" \
    in msg, msg
assert not os.path.isfile(frame_path(s.bake_folder, "rain", 1, "exr"))
print("RAIN BLENDER OK")
