"""Turned obstacles: a tilted board is a turned box (its own box, its half-sizes along its own
axes, its world rotation), and the dam break's water runs up it where its world bounding box
(what the addon took before) would have walled the whole wedge off; a paddle keyed to turn is
a turned box at every frame (the identity where it has not turned yet); a mirrored one is
still a box; a sheared one falls back to its world bounding box."""
import glob
import math
import os

import bpy
import numpy as np
from mathutils import Matrix

import in_blender

in_blender.enable()
from hydrobake.blender import jobs  # noqa: E402
from hydrobake.blender.bridge import meshes  # noqa: E402
from hydrobake.core import vdb  # noqa: E402

in_blender.empty_file("ramp.blend")
scene = bpy.context.scene
domain, column, f = in_blender.dam_break((32, 16, 16), frames=(1, 12), substeps=4)
ramp = in_blender.new_box("Ramp", (0.5, 0.5, 0.03), (0.6, 0.25, 0.15))
ramp.rotation_euler.y = math.radians(-35.0)  # its +x end up
board = bpy.data.collections.new("Board")
scene.collection.children.link(board)
board.objects.link(ramp)
f.obstacles = board
scene.frame_set(1)


def quat(obj):
    q = obj.matrix_world.to_quaternion()
    return np.array((q.w, q.x, q.y, q.z))


(kind, c, e, q), = in_blender.fluid_inputs(domain)["obstacles"]
assert kind == "turned_box", kind
assert np.allclose(c, (0.6, 0.25, 0.15), atol=1e-6) and np.allclose(e, (0.25, 0.25, 0.015),
                                                                    atol=1e-6), (c, e)
assert np.allclose(q, quat(ramp), atol=1e-6) and abs(q[0] - math.cos(math.radians(17.5))) < 1e-6, q


def water_above_ramp():
    """The most baked density, over frames 6-12, in the voxels 3.5-5 cm above the ramp's
    surface around its middle: inside its world bounding box (9 cm, three voxels, and more
    from its sides), outside the ramp."""
    assert bpy.ops.hydrobake.bake(effect="fluid", object_name="Domain") == {"FINISHED"}
    folder = bpy.path.abspath(jobs.folder_of(domain, "fluid"))
    axis = np.array(ramp.matrix_world.to_3x3().col[0])
    normal = np.array(ramp.matrix_world.to_3x3().normalized().col[2])
    cell = 1.0 / 32
    most = 0.0
    for frame in range(6, 13):
        d = vdb.read(glob.glob(os.path.join(folder, f"*fluid_{frame:04d}.vdb"))[0])["density"]
        acc = d.getConstAccessor()
        for s in np.linspace(-0.12, 0.05, 8):
            for h in (0.035, 0.05):
                for y in (0.15, 0.25, 0.35):
                    p = np.array((0.6, y, 0.15)) + s * axis / np.linalg.norm(axis) + \
                        (0.015 + h) * normal
                    ijk = tuple(int(math.floor(v / cell)) for v in p)
                    most = max(most, acc.getValue(ijk))
    assert bpy.ops.hydrobake.free_bake(effect="fluid", object_name="Domain") == {"FINISHED"}
    return most


turned = water_above_ramp()
plain = meshes.turned_bounds
meshes.turned_bounds = lambda obj: None  # the addon before: every object its world box
try:
    walled = water_above_ramp()
finally:
    meshes.turned_bounds = plain
print("water above the ramp: turned", turned, "as its world box", walled)
assert turned > 300.0 and walled < 1.0, (turned, walled)
print("FLUID TURNED RAMP OK")

# A paddle keyed to turn a quarter about z over the bake: a turned box at every frame.
bpy.data.objects.remove(ramp)
paddle = in_blender.new_box("Paddle", (0.4, 0.03, 0.3), (0.6, 0.25, 0.15))
paddle.keyframe_insert("rotation_euler", index=2, frame=1)
paddle.rotation_euler.z = math.radians(90.0)
paddle.keyframe_insert("rotation_euler", index=2, frame=12)
for k in paddle.animation_data.action.fcurves[0].keyframe_points:
    k.interpolation = "LINEAR"
board.objects.link(paddle)
scene.frame_set(1)
inp = in_blender.fluid_inputs(domain)
(kind, c, e, q), = inp["obstacles"]
assert kind == "turned_box" and q == (1.0, 0.0, 0.0, 0.0), (kind, q)
assert np.allclose(e, (0.2, 0.015, 0.15), atol=1e-6), e
path = inp["obstacle_path"]
assert sorted(path) == list(range(2, 13)), sorted(path)
for frame, obs in path.items():
    (kind, c, e, q), = obs
    a = math.radians(90.0) * (frame - 1) / 11
    assert kind == "turned_box" and np.allclose(c, (0.6, 0.25, 0.15), atol=1e-6), (frame, c)
    assert np.allclose(e, (0.2, 0.015, 0.15), atol=1e-6), (frame, e)
    assert np.allclose(q, (math.cos(a / 2), 0, 0, math.sin(a / 2)), atol=1e-5), (frame, q)
assert bpy.ops.hydrobake.bake(effect="fluid", object_name="Domain") == {"FINISHED"}
assert bpy.ops.hydrobake.free_bake(effect="fluid", object_name="Domain") == {"FINISHED"}
print("FLUID TURNING PADDLE OK")

# Mirrored (a negative scale), still a box, half-sizes positive; sheared (a turned child of a
# parent scaled along x), its world bounding box.
bpy.data.objects.remove(paddle)
mirrored = in_blender.new_box("Mirrored", (-0.2, 0.1, 0.1), (0.3, 0.25, 0.2))
mirrored.rotation_euler.z = math.radians(30.0)
parent = bpy.data.objects.new("Stretch", None)
scene.collection.objects.link(parent)
parent.scale = (2.0, 1.0, 1.0)
sheared = in_blender.new_box("Sheared", (0.05, 0.05, 0.05), (0.35, 0.25, 0.3))
sheared.parent = parent
sheared.rotation_euler.z = math.radians(45.0)
for o in (mirrored, sheared):
    board.objects.link(o)
scene.frame_set(1)
bpy.context.view_layer.update()
at = {o.name: k for k, o in enumerate(board.all_objects)}
obs = in_blender.fluid_inputs(domain)["obstacles"]
kind, c, e, q = obs[at["Mirrored"]]
assert kind == "turned_box" and np.allclose(e, (0.1, 0.05, 0.05), atol=1e-6), (kind, e)
turn = Matrix.Rotation(math.radians(30.0), 3, "Z")
got = np.array([[1 - 2 * (q[2] ** 2 + q[3] ** 2), 2 * (q[1] * q[2] - q[0] * q[3])],
                [2 * (q[1] * q[2] + q[0] * q[3]), 1 - 2 * (q[1] ** 2 + q[3] ** 2)]])
assert np.allclose(np.abs(got), np.abs(np.array(turn)[:2, :2]), atol=1e-5), (got, turn)
kind, c, e = obs[at["Sheared"]]
lo, hi = meshes.world_bounds(sheared)
assert kind == "box" and np.allclose(e, (hi - lo) / 2, atol=1e-6), (kind, e)
print("FLUID MIRRORED AND SHEARED OK")
