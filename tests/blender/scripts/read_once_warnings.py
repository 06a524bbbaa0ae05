"""What a bake reads once, at its first frame, though it may move: a pool's ground. One that is
animated, constrained or deformed is named in a warning (the bake does not follow it); a still
one, and one under a Subdivision only, is not. The fluid's obstacles are followed frame by
frame (fluid_moving_obstacles.py), so they are never named."""
import bpy

import in_blender

in_blender.enable()
from hydrobake.blender import jobs  # noqa: E402

in_blender.empty_file("read_once.blend")
scene = bpy.context.scene


def warnings_of(obj, effect):
    job = jobs.Job(bpy.context, obj, effect)
    try:
        return [w for w in job.warnings if "read once" in w]
    finally:
        job.runner.effect.close()
        del getattr(obj, f"hydrobake_{effect}")[jobs.BAKING]


# --- caustics: a still floor, then one keyed to sink --------------------------------------
pool = in_blender.new_plane("Pool")
pool.data.materials.append(bpy.data.materials.new("Water"))
floor = in_blender.new_plane("Floor")
floor.scale, floor.location = (3.0, 3.0, 1.0), (0.0, 0.0, -0.5)
floor.modifiers.new("Smooth", "SUBSURF")  # still: its shape depends on the mesh alone
c = pool.hydrobake_caustics
c.enabled, c.ground_object = True, floor
c.use_scene_range, c.frame_start, c.frame_end = False, 3, 4
c.water.width, c.map_resolution = 32, 64
assert warnings_of(pool, "caustics") == []
floor.keyframe_insert("location", frame=1)
floor.location.z = -0.8
floor.keyframe_insert("location", frame=10)
got = warnings_of(pool, "caustics")
assert got == ["Ground: 'Floor' is animated, constrained or deformed, but is read once, as "
               "it is at the bake's first frame (3): the bake does not follow it"], got
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
print("READ ONCE WARNINGS OK")
