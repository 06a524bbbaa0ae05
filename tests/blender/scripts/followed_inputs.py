"""Inputs that move are followed frame by frame, never read once at the first frame: a pool's
Ground and Source and the fluid's obstacles. (A curve is a Source and a metaball a Disturber
too.) A keyed Ground's heights and a keyed Source's
footprint are taken at every frame where they change (a still one, and one under a
Subdivision only, has no path); the bake keeps the water's volume over a sinking floor and
pours where the source is. No warning names any of them."""
import glob
import os

import bpy
import numpy as np

import in_blender

in_blender.enable()
from hydrobake.blender import jobs  # noqa: E402

in_blender.empty_file("followed.blend")
scene = bpy.context.scene


def warnings_of(obj, effect):
    job = jobs.Job(bpy.context, obj, effect)
    try:
        return job.warnings
    finally:
        job.runner.effect.close()
        del getattr(obj, f"hydrobake_{effect}")[jobs.BAKING]


# --- caustics: a still floor, then one keyed to sink (followed); a keyed source ------------
pool = in_blender.new_plane("Pool")
pool.data.materials.append(bpy.data.materials.new("Water"))
floor = in_blender.new_plane("Floor")
floor.scale, floor.location = (3.0, 3.0, 1.0), (0.0, 0.0, -0.5)
floor.modifiers.new("Smooth", "SUBSURF")  # still: its shape depends on the mesh alone
c = pool.hydrobake_caustics
c.enabled, c.ground_object = True, floor
c.use_scene_range, c.frame_start, c.frame_end = False, 3, 5
c.water.width, c.map_resolution = 32, 64
assert warnings_of(pool, "caustics") == []
assert in_blender.effect_inputs(pool, "caustics")["ground_path"] == {}
floor.location.z = -0.5
floor.keyframe_insert("location", frame=1)
floor.keyframe_insert("location", frame=4)  # still over 3..4, then sinking
floor.location.z = -0.8
floor.keyframe_insert("location", frame=10)
assert warnings_of(pool, "caustics") == []
inp = in_blender.effect_inputs(pool, "caustics")
assert sorted(inp["ground_path"]) == [5], sorted(inp["ground_path"])
sank = inp["ground"] - inp["ground_path"][5]
scene.frame_set(5)
want = -0.5 - floor.matrix_world.translation.z
assert want > 0.001 and np.allclose(sank, want, atol=1e-5), (want, sank.min(), sank.max())
# baked: the water keeps its volume and sinks with the floor (a flat floor: by as much)
c.water.rain_rate = 0.0
assert bpy.ops.hydrobake.bake(effect="caustics", object_name="Pool") == {"FINISHED"}
from hydrobake.core import exr  # noqa: E402
water = [exr.read(*glob.glob(os.path.join(bpy.path.abspath(c.bake_folder),
                                          f"*water_{f:04d}.exr"))) for f in (4, 5)]
vol = [float(w["depth"].astype(np.float64).sum()) for w in water]
assert abs(vol[1] - vol[0]) < 1e-6 * vol[0], vol
fell = float(np.mean(water[0]["height"]) - np.mean(water[1]["height"]))
assert abs(fell - want) < 1e-4, (fell, want)
assert bpy.ops.hydrobake.free_bake(effect="caustics", object_name="Pool") == {"FINISHED"}
tap = in_blender.new_plane("Tap")
tap.scale, tap.location = (0.1, 0.1, 1.0), (-0.5, 0.0, 0.3)
c.source_object, c.source_rate = tap, 0.2
assert warnings_of(pool, "caustics") == []
inp = in_blender.effect_inputs(pool, "caustics")
assert inp["sources_path"] == {} and inp["sources"].max() == np.float32(0.2)
tap.keyframe_insert("location", frame=4)
tap.location.x = 0.5
tap.keyframe_insert("location", frame=5)
assert warnings_of(pool, "caustics") == []
inp = in_blender.effect_inputs(pool, "caustics")
assert sorted(inp["sources_path"]) == [5], sorted(inp["sources_path"])
cols = [np.nonzero(a.any(axis=0))[0] for a in (inp["sources"], inp["sources_path"][5])]
cell = 2.0 / 32  # the pool is 2 m wide, 32 cells
assert abs((cols[1].mean() - cols[0].mean()) * cell - 1.0) < 1e-6, cols  # moved 1 m along x
# baked: frame 5 pours 0.2 m/s more into the pool than it drains (the floor's sinking aside)
assert bpy.ops.hydrobake.bake(effect="caustics", object_name="Pool") == {"FINISHED"}
depth = [exr.read(*glob.glob(os.path.join(bpy.path.abspath(c.bake_folder),
                                          f"*water_{f:04d}.exr")))["depth"] for f in (4, 5)]
poured = float(depth[1].astype(np.float64).sum() - depth[0].astype(np.float64).sum())
want = float(inp["sources_path"][5].astype(np.float64).sum()) * c.water.dt
assert abs(poured - want) < 1e-3 * want, (poured, want)
assert bpy.ops.hydrobake.free_bake(effect="caustics", object_name="Pool") == {"FINISHED"}
# a curve as the Source (a bevelled circle: a ring) pours under its footprint, its hole dry;
# a metaball family's member as the Disturber presses where the family's surface crosses
bpy.ops.curve.primitive_bezier_circle_add(radius=0.4, location=(0.0, 0.0, 0.3))
ring = bpy.context.active_object
ring.data.bevel_depth = 0.05
c.source_object = ring
under = in_blender.effect_inputs(pool, "caustics")["sources"] > 0
annulus = 2 * np.pi * 0.4 * 0.1 / cell ** 2  # cells under the ring's tube
assert abs(under.sum() / annulus - 1.0) < 0.25 and not under[14:18, 14:18].any(), \
    (under.sum(), annulus)
c.source_object = None
blobs = []
for x in (-0.5, 0.5):
    bpy.ops.object.metaball_add(type="BALL", radius=0.3, location=(x, 0.0, 0.0))
    blobs.append(bpy.context.active_object)
blobs[0].name, blobs[1].name = "Blob", "Blob.001"
c.disturber_object = blobs[1]
pressed = in_blender.effect_inputs(pool, "caustics")["footprints"][3]
cols = np.nonzero(pressed.any(axis=0))[0]
assert pressed is not None and cols.min() < 8 and cols.max() > 24, cols  # both blobs
c.disturber_object = None
c.enabled = False

# --- fluid: one still rock, one swaying under a Wave, one following an Empty: followed ------
domain, column, f = in_blender.dam_break((16, 8, 8), frames=(1, 3), substeps=2)
rocks = bpy.data.collections.new("Rocks")
scene.collection.children.link(rocks)
for name, y in (("Still", 0.1), ("Swaying", 0.3), ("Led", 0.5)):
    rocks.objects.link(in_blender.new_box(name, (0.05, 0.05, 0.05), (0.9, y, 0.05)))
bpy.data.objects["Swaying"].modifiers.new("Wave", "WAVE")
leader = bpy.data.objects.new("Leader", None)
scene.collection.objects.link(leader)
leader.location.z = 0.3
leader.keyframe_insert("location", frame=1)
leader.location.z = 0.2
leader.keyframe_insert("location", frame=3)
bpy.data.objects["Led"].constraints.new("COPY_LOCATION").target = leader
f.obstacles = rocks
assert warnings_of(domain, "fluid") == []
job = jobs.Job(bpy.context, domain, "fluid")
try:
    inp = job.runner.effect.inputs
    first, path = inp["obstacles"], inp["obstacle_path"]
    assert sorted(path) == [2, 3], sorted(path)
    for obs in path.values():
        assert obs[0] == first[0]  # the still rock stays
        assert obs[2][1][2] < first[2][1][2]  # the led one comes down with its leader
finally:
    job.runner.effect.close()
    del domain.hydrobake_fluid[jobs.BAKING]
print("FOLLOWED INPUTS OK")
