"""Snow on moving objects is simulated frame by frame from their animation, whatever frame the
scene is on when Bake is pressed: a cube upside down at frame 1 and upright from frame 2
takes snow on its top over frames 2-5 only, also when its parent turns it; a roof over it
from frame 2 on (far away at frame 1) shelters it from frame 2 on."""
import json
import math
import os

import bpy
import numpy as np

import in_blender

in_blender.enable()
from hydrobake.core import exr  # noqa: E402
from hydrobake.core.bake.cache import frame_path  # noqa: E402

tmp = in_blender.args()[0]
bpy.ops.wm.save_as_mainfile(filepath=os.path.join(tmp, "animated.blend"))
scene = bpy.context.scene
cube = bpy.data.objects["Cube"]
cube.rotation_euler.x = math.pi
cube.keyframe_insert("rotation_euler", frame=1)
cube.rotation_euler.x = 0.0
cube.keyframe_insert("rotation_euler", frame=2)
s = in_blender.snow(cube, (2, 5), 1000, 64)
s.snow.wind = (0.0, 0.0, 0.0)
s.snow.flutter_amplitude = 0.0


def face(nz):
    """Mean coverage of the last frame on the face with local normal (0, 0, nz)."""
    cov = exr.read(frame_path(s.bake_folder, "coverage", 5, "exr"))["A"]
    p = next(p for p in cube.data.polygons if round(p.normal.z) == nz)
    us = np.array([cube.data.uv_layers.active.data[i].uv[:] for i in p.loop_indices])
    lo, hi = (us.min(0) * 64).astype(int), np.ceil(us.max(0) * 64).astype(int)
    return float(cov[lo[1]:hi[1], lo[0]:hi[0]].mean())


def bake(current):
    scene.frame_set(current)
    assert bpy.ops.hydrobake.bake(effect="snow", object_name="Cube") == {"FINISHED"}
    assert scene.frame_current == current
    with open(os.path.join(s.bake_folder, "manifest.json")) as f:
        frames = json.load(f)["frames"]
    got = frames, face(1), face(-1)
    assert bpy.ops.hydrobake.free_bake(effect="snow", object_name="Cube") == {"FINISHED"}
    return got


on5, on1 = bake(5), bake(1)
print("top, bottom coverage", on5[1:], on1[1:])
assert on5[0] == on1[0]  # the same bytes
assert on1[1] > 0.0 and on1[2] == 0.0, on1[1:]

# The same turn given by an animated parent (the cube itself keeps still).
cube.animation_data_clear()
cube.rotation_euler.x = 0.0
pivot = bpy.data.objects.new("Pivot", None)
scene.collection.objects.link(pivot)
pivot.rotation_euler.x = math.pi
pivot.keyframe_insert("rotation_euler", frame=1)
pivot.rotation_euler.x = 0.0
pivot.keyframe_insert("rotation_euler", frame=2)
cube.parent = pivot
parented = bake(1)
print("parented top, bottom coverage", parented[1:])
assert parented[1] > 0.0 and parented[2] == 0.0, parented[1:]

# A roof (collider) just over the cube from frame 2 on, 10 m aside at frame 1. (Flakes that
# start between the two still land.)
bpy.ops.mesh.primitive_plane_add(size=4, location=(10, 0, 1.005))
roof = bpy.context.object
roof.keyframe_insert("location", frame=1)
roof.location.x = 0.0
roof.keyframe_insert("location", frame=2)
shelter = bpy.data.collections.new("Shelter")
shelter.objects.link(roof)
s.colliders = shelter
roofed = bake(1)
print("roofed top, bottom coverage", roofed[1:])
assert roofed[1] < 0.1 * on1[1] and roofed[2] == 0.0, roofed[1:]
print("SNOW ANIMATED OK")
