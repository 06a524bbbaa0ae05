"""Snowfall per square metre does not depend on the object's size: a 1 m plate and an 8 m
plate under the same Flake Density get the same mean snow depth (Auto Volume fits a volume
20 times larger around the big plate, and Flake Density fills it with as many more flakes).
Each plate's texture has the same texels per metre, so a flake's stamp covers the same area."""
import json
import os

import bpy

import in_blender

in_blender.enable()
from hydrobake.core import exr  # noqa: E402
from hydrobake.core.bake.cache import frame_path  # noqa: E402

tmp = in_blender.args()[0]
bpy.data.objects.remove(bpy.data.objects["Cube"])
bpy.ops.wm.save_as_mainfile(filepath=os.path.join(tmp, "density.blend"))
depth, counts = {}, {}
for name, size, x in (("Small", 1.0, -20.0), ("Large", 8.0, 20.0)):
    bpy.ops.mesh.primitive_plane_add(size=size, location=(x, 0, 0))
    o = bpy.context.object
    o.name = name
    s = in_blender.snow(o, (1, 8), 4000.0, int(16 * size))
    s.snow.wind = (0.0, 0.0, 0.0)
    s.snow.depth_per_flake = 0.01
    assert bpy.ops.hydrobake.bake(effect="snow", object_name=name) == {"FINISHED"}
    depth[name] = float(exr.read(frame_path(s.bake_folder, "depth", 8, "exr"))["Y"].mean())
    with open(os.path.join(s.bake_folder, "manifest.json")) as f:
        counts[name] = json.load(f)["params"]["snow"]["flake_count"]
print("mean depth (m)", depth, "flakes", counts)
# The panel's estimate (from bounding boxes) is the bake's count for a still, plain plate.
from hydrobake.blender.effects import snow as snow_effect  # noqa: E402
for name in ("Small", "Large"):
    o = bpy.data.objects[name]
    assert snow_effect.estimate(o, o.hydrobake_snow)[0] == counts[name], name


class Layout:
    """What a panel draws, recorded: enough of UILayout for the effects' draw_settings."""
    def __init__(self, out):
        self.out, self.active, self.enabled = out, True, True

    def column(self, **_):
        return Layout(self.out)

    row = box = column

    def prop(self, data, name, **_):
        self.out.append(("prop", name, self.active))

    def label(self, text="", **_):
        self.out.append(("label", text, self.active))


drawn = []
snow_effect.SnowBlender.draw_settings(Layout(drawn), bpy.data.objects["Large"].hydrobake_snow)
print(drawn)
assert ("label", f"About {counts['Large']:,} flakes in 9.0 x 9.0 x 1.6 m", True) in drawn, drawn
assert ("prop", "flake_count", False) in drawn and ("prop", "volume_min", False) in drawn
assert ("prop", "temperature", True) in drawn
assert counts["Large"] > 15 * counts["Small"], counts
assert depth["Small"] > 0.0, depth
assert abs(depth["Large"] / depth["Small"] - 1.0) < 0.15, depth
# A preset sets the density too (Blizzard: five times the paper's).
o = bpy.data.objects["Small"]
assert bpy.ops.hydrobake.free_bake(effect="snow", object_name="Small") == {"FINISHED"}
assert bpy.ops.hydrobake.apply_preset(effect="snow", object_name="Small",
                                      preset="Blizzard") == {"FINISHED"}
assert o.hydrobake_snow.flake_density == 5 * 3125.0, o.hydrobake_snow.flake_density
# A density the kernel cannot hold in the Auto Volume is refused, naming what to change.
o.hydrobake_snow.flake_density = 1e6
o.scale = (40.0, 40.0, 1.0)
try:
    bpy.ops.hydrobake.bake(effect="snow", object_name="Small")
except RuntimeError as exc:
    msg = str(exc)
else:
    raise AssertionError("a 1e6 per m³ density over a 40 m plate was baked")
print(msg)
assert "Flake Density 1e+06 per m³" in msg and "the most is 20000000" in msg, msg
assert "turn off Auto Volume" in msg, msg
print("SNOW DENSITY OK")
