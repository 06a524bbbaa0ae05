"""Local paint captured from the baked surface: vertices selected on it at frame 2 become a
stroke of texture 1 (a point mesh in the domain's paint collection), and the re-bake puts the
texture there at frame 2, not before, and carries it on. Weights and colours painted on the
surface give a stroke whose coverage is theirs."""
import os

import bpy
import numpy as np

import in_blender

in_blender.enable()
from hydrobake.core import vdb  # noqa: E402
from hydrobake.core.bake.cache import frame_path  # noqa: E402

tmp = in_blender.args()[0]
bpy.ops.wm.save_as_mainfile(filepath=os.path.join(tmp, "capture.blend"))



def blend1(frame):
    """(grid of blend_1, its index -> world transform)."""
    g = vdb.read(frame_path(s.bake_folder, "fluid", frame, "vdb"))["blend_1"]
    return g, g.transform


domain, fill, s = in_blender.dam_break((32, 16, 16), frames=(1, 3))
s.fluid.paint_duration = 10.0
assert bpy.ops.hydrobake.bake(effect="fluid", object_name="Domain") == {"FINISHED"}
surf = bpy.data.objects["HBK_Domain_surface"]
bpy.context.scene.frame_set(2)
bpy.context.view_layer.objects.active = surf
co = np.empty(len(surf.data.vertices) * 3, np.float32)
surf.data.vertices.foreach_get("co", co)
co = co.reshape(-1, 3)
top = co[:, 2] > np.percentile(co[:, 2], 80)  # the top fifth of the fluid at frame 2
surf.data.vertices.foreach_set("select", top)
for items in (surf.data.edges, surf.data.polygons):  # else Edit Mode selects their vertices
    items.foreach_set("select", np.zeros(len(items), bool))
# Selected in Edit Mode, then the scene moved on: the mesh keeps frame 2, and so does the stroke.
bpy.ops.object.mode_set(mode="EDIT")
bpy.context.scene.frame_set(3)
assert bpy.ops.hydrobake.fluid_capture_paint(texture=1, source="SELECTION") == {"FINISHED"}
with np.load(frame_path(s.bake_folder, "surface", 3, "npz")) as f3:
    assert len(surf.data.vertices) == len(f3["positions"]) != len(top)  # frame 3 shown again
bpy.context.scene.frame_set(2)
stroke = bpy.data.objects["HBK_Domain_paint_2"]
assert stroke in s.paint_collection.objects[:] and stroke.hydrobake_fluid_paint.enabled
assert stroke.hydrobake_fluid_paint.frame == 2 and stroke.hydrobake_fluid_paint.texture == 1
assert len(stroke.data.vertices) == top.sum(), (len(stroke.data.vertices), top.sum())

# Re-baked: texture 1 appears at frame 2 on the painted top, not low in the fluid, not before.
assert bpy.ops.hydrobake.free_bake(effect="fluid", object_name="Domain") == {"FINISHED"}
assert bpy.ops.hydrobake.bake(effect="fluid", object_name="Domain") == {"FINISHED"}
bpy.context.scene.frame_set(1)
g1, _ = blend1(1)
assert g1.activeVoxelCount() == 0 or g1.evalMinMax()[1] < 1e-6
bpy.context.scene.frame_set(2)
surf = bpy.data.objects["HBK_Domain_surface"]  # made again by the bake
bpy.context.view_layer.objects.active = surf
b = np.empty(len(surf.data.vertices), np.float32)
surf.data.attributes["blend_1"].data.foreach_get("value", b)
surf.data.vertices.foreach_get("co", co.reshape(-1))
low = co[:, 2] < np.percentile(co[:, 2], 30)
assert b[top].mean() > 0.8, b[top].mean()  # the same surface as before: the paint lies on it
assert b[low].max() < 0.05, b[low].max()
bpy.context.scene.frame_set(3)
g3, _ = blend1(3)
assert g3.evalMinMax()[1] > 0.8  # it goes on with the fluid
print("FLUID CAPTURE SELECTION OK")

# Weights and colours: the stroke's coverage is the painted value at each vertex.
bpy.context.scene.frame_set(2)
n = len(surf.data.vertices)
want = np.where(top, 0.25 + 0.5 * (np.arange(n) % 2), 0.0).astype(np.float32)
group = surf.vertex_groups.new(name="Paint")
for i in np.flatnonzero(want):
    group.add([int(i)], float(want[i]), "REPLACE")
surf.vertex_groups.active = group
colour = surf.data.color_attributes.new("Col", "FLOAT_COLOR", "CORNER")
corner_vert = np.empty(len(surf.data.loops), np.int32)
surf.data.loops.foreach_get("vertex_index", corner_vert)
rgba = np.repeat(want[corner_vert], 4).reshape(-1, 4)
rgba[:, 3] = 1.0
colour.data.foreach_set("color", rgba.ravel())
surf.data.color_attributes.active_color = colour
for source in ("WEIGHTS", "COLOR"):
    before = set(s.paint_collection.objects)
    assert bpy.ops.hydrobake.fluid_capture_paint(texture=1, source=source) == {"FINISHED"}
    (new,) = set(s.paint_collection.objects) - before
    cov = np.empty(len(new.data.vertices), np.float32)
    new.data.attributes["coverage"].data.foreach_get("value", cov)
    np.testing.assert_allclose(np.sort(cov), np.sort(want[want > 0]), atol=1e-6)
# Black paint over a white colour attribute, inverted: the same coverage.
rgba[:, :3] = 1.0 - rgba[:, :3]
colour.data.foreach_set("color", rgba.ravel())
before = set(s.paint_collection.objects)
assert bpy.ops.hydrobake.fluid_capture_paint(texture=1, source="COLOR", invert=True) == {
    "FINISHED"}
(new,) = set(s.paint_collection.objects) - before
cov = np.empty(len(new.data.vertices), np.float32)
new.data.attributes["coverage"].data.foreach_get("value", cov)
np.testing.assert_allclose(np.sort(cov), np.sort(want[want > 0]), atol=1e-6)
surf.vertex_groups.clear()
try:
    bpy.ops.hydrobake.fluid_capture_paint(texture=1, source="WEIGHTS")
    raise AssertionError("captured weights with no vertex group")
except RuntimeError as exc:
    assert "From = WEIGHTS: the surface has no active vertex group" in str(exc), exc
# Reach beyond the grid's limit is refused with the limit, which can then be typed in.
stroke.hydrobake_fluid_paint.reach = 10.0
try:
    bpy.ops.hydrobake.bake(effect="fluid", object_name="Domain")
    raise AssertionError("baked with Reach = 10 m")
except RuntimeError as exc:
    msg = str(exc)
assert "HBK_Domain_paint_2: Reach = 10 m: must be at most " in msg, msg
stroke.hydrobake_fluid_paint.reach = float(msg.split("at most ")[1].split(" m")[0])
assert bpy.ops.hydrobake.free_bake(effect="fluid", object_name="Domain") == {"FINISHED"}
assert bpy.ops.hydrobake.bake(effect="fluid", object_name="Domain") == {"FINISHED"}
print("FLUID CAPTURE WEIGHTS OK")
