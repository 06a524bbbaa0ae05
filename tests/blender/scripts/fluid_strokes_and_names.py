"""Fluid inputs that used to do nothing without a word, and baked objects found after a
rename: more obstacles than the core takes, a paint stroke before the bake's first frame
(refused, naming the setting and its range), an animated paint Empty (it paints where it is
at its Frame, not where it is when Bake is pressed), Capture Paint / Capture Feature Rule on
the surface of a domain renamed since its bake, and the textured surface and the Volume
object renamed by the artist (a re-bake reuses them, Free removes them)."""

import os

import bpy
import numpy as np

import in_blender

in_blender.enable()
from hydrobake.core import vdb  # noqa: E402
from hydrobake.core.bake.cache import frame_path  # noqa: E402

tmp = in_blender.empty_file("strokes.blend")
scene = bpy.context.scene


def refused(**kw):
    try:
        bpy.ops.hydrobake.bake(**kw)
    except RuntimeError as exc:
        assert "Traceback" not in str(exc), exc
        return str(exc)
    raise AssertionError("the bake did not refuse")


domain, column, s = in_blender.dam_break((16, 8, 8), textures=2, frames=(1, 3), substeps=2)
column.hide_render = True

# More obstacles than the core takes: the 65th and later were left out (fluid through them).
obstacles = bpy.data.collections.new("Rocks")
scene.collection.children.link(obstacles)
for i in range(65):
    rock = in_blender.new_box(f"Rock {i}", (0.02, 0.02, 0.02), (0.9, 0.05 + 0.006 * i, 0.02))
    obstacles.objects.link(rock)
s.obstacles = obstacles
msg = refused(effect="fluid", object_name="Domain")
assert "Obstacles: 'Rocks' holds 65 objects: must hold at most 64" in msg, msg
bpy.data.objects.remove(bpy.data.objects["Rock 64"])
s.obstacles = None

# A paint Empty: texture 1 into the foot of the column at frame 2. It is keyed to wait far
# off (x = 0.9, where there is no water) until frame 2, and the bake starts on frame 1.
paint = bpy.data.collections.new("Paint")
scene.collection.children.link(paint)
brush = bpy.data.objects.new("Brush", None)
paint.objects.link(brush)
brush.empty_display_size = 0.08
p = brush.hydrobake_fluid_paint
p.enabled, p.texture = True, 1
s.paint_collection = paint
# Frame 0 is before the bake's first frame, and its paint would still show then (2.5 s).
p.frame = 0
msg = refused(effect="fluid", object_name="Domain")
assert "Brush: Frame = 0: must be in [1, 3], the bake's frame range" in msg, msg
p.frame = 2
brush.location = (0.9, 0.25, 0.4)
brush.keyframe_insert("location", frame=1)
brush.location = (0.12, 0.25, 0.1)
brush.keyframe_insert("location", frame=2)
scene.frame_set(1)
assert brush.matrix_world.translation.x > 0.8
assert bpy.ops.hydrobake.bake(effect="fluid", object_name="Domain") == {"FINISHED"}
assert scene.frame_current == 1  # the scene is back on its frame
blend = vdb.read_grid(frame_path(s.bake_folder, "fluid", 2, "vdb"), "blend_1")
cell = 1.0 / 16
at = tuple(int(round(c / cell)) for c in (0.12, 0.25, 0.1))
assert blend[at] > 0.5, blend[at]  # painted where the Empty is at frame 2
print("FLUID STROKES OK")

# The domain renamed after its bake: its surface still captures, into the renamed domain.
domain.name = "Tank"
surf = bpy.data.objects["HBK_Domain_surface"]
scene.frame_set(3)
surf.data.vertices.foreach_set("select", np.ones(len(surf.data.vertices), bool))
bpy.context.view_layer.objects.active = surf
assert bpy.ops.hydrobake.fluid_capture_rule(texture=1, feature="DENSITY") == {"FINISHED"}
assert len(domain.hydrobake_fluid.rules) == 1
assert bpy.ops.hydrobake.fluid_capture_paint(texture=1) == {"FINISHED"}
assert any(o.hydrobake_fluid_paint.enabled and o.type == "MESH" for o in paint.objects)
domain.hydrobake_fluid.rules.remove(0)
for o in [o for o in paint.objects if o.type == "MESH"]:
    bpy.data.objects.remove(o)
domain.name = "Domain"
print("FLUID RENAMED DOMAIN OK")

# The artist renames the baked objects: a re-bake keeps them (and a Volume shown in renders
# stays shown), Free removes them.
surf.name, vol = "Water", bpy.data.objects["HBK_Domain_volume"]
vol.name = "Water volume"
vol.hide_render = False
assert bpy.ops.hydrobake.bake(effect="fluid", object_name="Domain") == {"FINISHED"}
hbk = sorted(o.name for o in bpy.data.objects if o.type in ("VOLUME",) or
             "hydrobake_domain" in o)
assert hbk == ["Water", "Water volume"], hbk
assert not vol.hide_render
assert vol.data.filepath.endswith("_Domain_fluid_fluid_0001.vdb") and vol.data.materials[0] is not None
scene.frame_set(2)
assert len(bpy.data.objects["Water"].data.vertices) > 0
# A re-bake into another Cache Folder too (found by the files of the folder baked into, the
# renamed pair was left showing the old bake beside a new pair: monkey --renames 834).
s.cache_dir = os.path.join(tmp, "elsewhere", "")
assert bpy.ops.hydrobake.bake(effect="fluid", object_name="Domain") == {"FINISHED"}
hbk = sorted(o.name for o in bpy.data.objects if o.type in ("VOLUME",) or
             "hydrobake_domain" in o)
assert hbk == ["Water", "Water volume"], hbk
vol = bpy.data.objects["Water volume"]
assert os.path.join(tmp, "elsewhere") in bpy.path.abspath(vol.data.filepath), vol.data.filepath
assert bpy.ops.hydrobake.free_bake(effect="fluid", object_name="Domain") == {"FINISHED"}
left = sorted(o.name for o in bpy.data.objects if o.type == "VOLUME" or "hydrobake_domain" in o)
assert left == [], left
print("FLUID RENAMED OBJECTS OK")

# Parameters prepare sets itself (from the domain's box, the scene's frame rate) or Blender
# never uses: drawn inactive and refused as command-line overrides, not silently replaced.
from hydrobake.blender import effects  # noqa: E402
derived = effects.BLENDER_EFFECTS["fluid"].derived(s)
assert {"fluid.box_min", "fluid.box_max", "fluid.dt", "fluid.texture_feature",
        "fluid.seed"} <= set(derived), derived
assert "fluid.surface_threshold" not in derived  # the SPH's metaballs use it
s.fluid.source = "VELOCITY_GRID"
assert "fluid.surface_threshold" in effects.BLENDER_EFFECTS["fluid"].derived(s)
print("FLUID DERIVED OK")
