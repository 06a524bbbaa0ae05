"""A keyed paddle in the fluid's Obstacles collection is followed frame by frame: the bake's
inputs hold where it is at each later frame (its keyed place, with no read-once warning), and
the baked water is kept out of where the paddle is at the last frame, where water stands when
the paddle stays where it starts (as a bake that read it once had it)."""
import glob
import os

import bpy
import numpy as np

import in_blender

in_blender.enable()
from hydrobake.blender import jobs  # noqa: E402
from hydrobake.core import vdb  # noqa: E402

in_blender.empty_file("paddle.blend")
scene = bpy.context.scene
domain, column, f = in_blender.dam_break((32, 16, 16), frames=(1, 12), substeps=4)
paddle = in_blender.new_box("Paddle", (0.24, 0.3, 0.3), (0.9, 0.25, 0.15))
for frame, x in ((1, 0.9), (12, 0.45)):
    paddle.location.x = x
    paddle.keyframe_insert("location", index=0, frame=frame)
for k in paddle.animation_data.action.fcurves[0].keyframe_points:
    k.interpolation = "LINEAR"
paddles = bpy.data.collections.new("Paddles")
scene.collection.children.link(paddles)
paddles.objects.link(paddle)
f.obstacles = paddles
scene.frame_set(1)

# What the bake takes: the paddle at its keyed places, every later frame.
job = jobs.Job(bpy.context, domain, "fluid")
try:
    assert not [w for w in job.warnings if "read once" in w], job.warnings
    inp = job.runner.effect.inputs
    (kind, c0, e0), = inp["obstacles"]
    assert kind == "box" and np.allclose(c0, (0.9, 0.25, 0.15), atol=1e-6), c0
    assert np.allclose(e0, (0.12, 0.15, 0.15), atol=1e-6), e0
    path = inp["obstacle_path"]
    assert sorted(path) == list(range(2, 13)), sorted(path)
    for frame, obs in path.items():
        (kind, c, e), = obs
        assert abs(c[0] - (0.9 - 0.45 * (frame - 1) / 11)) < 1e-5 and np.allclose(e, e0), (frame, c)
finally:
    job.runner.effect.close()
    del domain.hydrobake_fluid[jobs.BAKING]

# A ball is a sphere, followed as it drops: its centre where its keys put it, its radius kept.
bpy.ops.mesh.primitive_uv_sphere_add(radius=0.1, location=(0.7, 0.25, 0.45))
ball = bpy.context.active_object
ball.rotation_euler = (0.3, 0.5, 0.0)  # (turned: still round)
ball.keyframe_insert("location", index=2, frame=1)
ball.location.z = 0.15
ball.keyframe_insert("location", index=2, frame=12)
for k in ball.animation_data.action.fcurves[0].keyframe_points:
    k.interpolation = "LINEAR"
bpy.ops.mesh.primitive_ico_sphere_add(radius=0.05, subdivisions=2, location=(0.2, 0.4, 0.1))
pebble = bpy.context.active_object
for o in (ball, pebble):
    paddles.objects.link(o)
job = jobs.Job(bpy.context, domain, "fluid")
try:
    inp = job.runner.effect.inputs
    kinds = {o.name: ob[0] for o, ob in zip(paddles.all_objects, inp["obstacles"])}
    assert kinds == {"Paddle": "box", "Sphere": "sphere", "Icosphere": "sphere"}, kinds
    at = {o.name: k for k, o in enumerate(paddles.all_objects)}
    kind, c, r = inp["obstacles"][at["Icosphere"]]
    assert np.allclose(c, (0.2, 0.4, 0.1), atol=1e-6) and abs(r - 0.05) < 1e-6, (c, r)
    for frame, obs in [(1, inp["obstacles"])] + sorted(inp["obstacle_path"].items()):
        kind, c, r = obs[at["Sphere"]]
        z = 0.45 - 0.3 * (frame - 1) / 11 if frame < 12 else 0.15
        assert np.allclose(c, (0.7, 0.25, z), atol=1e-5) and abs(r - 0.1) < 1e-5, (frame, c, r)
        assert obs[at["Icosphere"]] == inp["obstacles"][at["Icosphere"]]
finally:
    job.runner.effect.close()
    del domain.hydrobake_fluid[jobs.BAKING]
for o in (ball, pebble):
    bpy.data.objects.remove(o)


def water_in_paddle():
    """The baked density, at frame 12, in the voxels of the paddle's middle slab there."""
    assert bpy.ops.hydrobake.bake(effect="fluid", object_name="Domain") == {"FINISHED"}
    folder = bpy.path.abspath(jobs.folder_of(domain, "fluid"))
    last, = glob.glob(os.path.join(folder, "*fluid_0012.vdb"))
    d = vdb.read(last)["density"]
    lo, hi = d.evalActiveVoxelBoundingBox()
    a = np.zeros(tuple(b - a + 1 for a, b in zip(lo, hi)), np.float32)
    d.copyToArray(a, ijk=lo)
    cell = 1.0 / 32  # a 1 m long domain in 32 voxels (x, y, z index from its corner)
    i = round(0.45 / cell) - lo[0]
    js = slice(round(0.15 / cell) - lo[1], round(0.35 / cell) - lo[1])
    ks = slice(max(0 - lo[2], 0), int(0.2 / cell) - lo[2])
    assert bpy.ops.hydrobake.free_bake(effect="fluid", object_name="Domain") == {"FINISHED"}
    return a[i, js, ks]


moved = water_in_paddle()
paddle.animation_data_clear()
paddle.location.x = 0.9  # where the keyed one starts: as a bake that read it once saw it
still = water_in_paddle()
print("moved", float(moved.max()), "still", float(still.max()))
assert moved.size and moved.max() == 0.0, moved.max()
assert still.max() > 100.0, still.max()  # the water there, had the paddle not come
print("FLUID MOVING OBSTACLES OK")
