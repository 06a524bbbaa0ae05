"""Caustics inputs from Blender: the ground from a height image, water poured in under a
source object (the volume grows by rate x footprint area x time), drained with a negative rate."""
import os

import bpy
import numpy as np

import in_blender

in_blender.enable()
from hydrobake.core import exr  # noqa: E402
from hydrobake.core.bake.cache import frame_path  # noqa: E402

tmp = in_blender.args()[0]
bpy.ops.wm.save_as_mainfile(filepath=os.path.join(tmp, "pond.blend"))
water = in_blender.new_plane("Pond")  # 2 m x 2 m at z = 0
img = bpy.data.images.new("depth", 32, 32, float_buffer=True)
ramp = np.tile(np.linspace(0.2, 1.0, 32, dtype=np.float32), (32, 1))
img.pixels.foreach_set(np.stack([ramp] * 3 + [np.ones_like(ramp)], -1).ravel())
src = in_blender.new_plane("Tap")
src.scale = (0.25, 0.25, 1)  # 0.5 m x 0.5 m footprint
src.location = (0, 0, 0.3)
s = water.hydrobake_caustics
s.enabled, s.ground_image, s.ground_image_scale = True, img, 1.0
s.source_object, s.source_rate = src, 0.1
s.use_scene_range, s.frame_start, s.frame_end = False, 1, 4
s.water.width, s.map_resolution, s.water.rain_rate = 32, 64, 0.0
assert bpy.ops.hydrobake.bake(effect="caustics", object_name="Pond") == {"FINISHED"}
cell = 2.0 / 32
vol = [float(exr.read(frame_path(s.bake_folder, "water", f, "exr"))["depth"].sum()) * cell**2
       for f in (1, 4)]
# 0.1 m/s over the 0.25 m^2 under the tap for 3 frames at 24 fps: 0.003125 m^3.
assert abs((vol[1] - vol[0]) - 0.1 * 0.25 * 3 / 24) < 0.1 * 0.1 * 0.25 * 3 / 24, vol
depth = exr.read(frame_path(s.bake_folder, "water", 1, "exr"))["depth"]
assert depth[:, 0].mean() < depth[:, -1].mean()  # the image's ramp: deeper towards +x
print("CAUSTICS SOURCES OK", vol)
