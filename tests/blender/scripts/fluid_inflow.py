"""The Inflow object: a tap pours from its shape only from Inflow Start to Inflow End (the
core's input is None outside them), a ball pours as a sphere, a keyed tap is followed frame
by frame (its path is exactly its keys'), with Source its water takes on the tap's own motion,
with Local Velocity its velocity turns with it, an Inflow outside the domain or ending before
it starts is refused by name, and a bake pours: the particles grow only in the pouring frames,
by the tap's flow; at Max Particles it stops, the bake foretells it before it starts, and its
end says so."""
import math

import bpy
import numpy as np

import in_blender

in_blender.enable()
from hydrobake.blender import jobs  # noqa: E402

in_blender.empty_file("inflow.blend")
domain, column, f = in_blender.dam_break((16, 8, 8), frames=(1, 8), substeps=2)
f.fill_object = in_blender.new_box("Puddle", (0.3, 0.5, 0.06), (0.85, 0.25, 0.03))
s = f.fluid.particle_spacing
tap = in_blender.new_box("Tap", (0.08, 0.08, 0.08), (0.3, 0.25, 0.4))
f.inflow_object, f.inflow_velocity = tap, (0.0, 0.0, -1.0)
f.inflow_start, f.inflow_end = 3, 5


def refused(text):
    in_blender.inputs_refused(domain, "fluid", text)


# a box tap, on for frames 3-5 of 1-8: None before and after, its box between
inputs = in_blender.fluid_inputs(domain)
flow = inputs["inflow"]
assert sorted(flow) == [1, 3, 6] and flow[1] is None and flow[6] is None, flow
kind, centre, half = flow[3]
assert kind == "box" and np.allclose(centre, (0.3, 0.25, 0.4)) and np.allclose(half, 0.04), \
    flow[3]
assert inputs["inflow_velocity"] == (0.0, 0.0, -1.0), inputs["inflow_velocity"]
print("FLUID INFLOW FRAMES OK")

# a ball pours as a sphere; a tap keyed to move is followed where it moves
bpy.ops.mesh.primitive_uv_sphere_add(radius=0.05, location=(0.3, 0.25, 0.4))
ball = bpy.context.active_object
f.inflow_object = ball
inputs = in_blender.fluid_inputs(domain)
assert inputs["inflow"][3][0] == "sphere" and abs(inputs["inflow"][3][2] - 0.05) < 1e-3, \
    inputs["inflow"][3]
f.inflow_object, f.inflow_start, f.inflow_end = tap, 1, 8
tap.keyframe_insert("location", frame=1)
tap.location.x = 0.7
tap.keyframe_insert("location", frame=8)
for fc in tap.animation_data.action.fcurves:
    for k in fc.keyframe_points:
        k.interpolation = "LINEAR"
inputs = in_blender.fluid_inputs(domain)
xs = {fr: sh[1][0] for fr, sh in inputs["inflow"].items()}
assert sorted(xs) == list(range(1, 9)), xs
assert all(abs(xs[fr] - (0.3 + 0.4 * (fr - 1) / 7)) < 1e-5 for fr in xs), xs
# Source: its water takes on the tap's own motion (0.4 m in 7 frames of 1/24 s along x):
# one velocity, moving at a constant speed; half of it at 0.5; none at 0
assert np.allclose(inputs["inflow_velocity"], (0.4 / 7 * 24, 0, -1), atol=1e-4), \
    inputs["inflow_velocity"]
f.inflow_source = 0.5
vel = in_blender.fluid_inputs(domain)["inflow_velocity"]
assert np.allclose(vel, (0.2 / 7 * 24, 0, -1), atol=1e-4), vel
f.inflow_source = 0.0
assert in_blender.fluid_inputs(domain)["inflow_velocity"] == (0.0, 0.0, -1.0)
f.inflow_source = 1.0
# eased in and out (Bezier keys): each frame's step takes the tap's motion over that step
# (the frame before to it; the first frame the second's)
for fc in tap.animation_data.action.fcurves:
    for k in fc.keyframe_points:
        k.interpolation = "BEZIER"
inputs = in_blender.fluid_inputs(domain)
xs = {fr: sh[1][0] for fr, sh in inputs["inflow"].items()}
vel = inputs["inflow_velocity"]
assert sorted(vel) == [1, 3, 4, 5, 6, 7, 8], sorted(vel)  # (frame 1 takes frame 2's)
at = {fr: vel[max(k for k in vel if k <= fr)] for fr in range(1, 9)}
for fr in range(2, 9):
    assert np.allclose(at[fr], ((xs[fr] - xs[fr - 1]) * 24, 0, -1), atol=1e-4), (fr, at[fr])
assert at[1] == at[2] and at[2][0] < at[4][0] and at[8][0] < at[4][0], at  # (eased)
tap.animation_data_clear()
tap.location.x = 0.3
# a ring (a mesh: its field) keyed to move: its field made once, placed where it is
bpy.ops.mesh.primitive_torus_add(major_radius=0.06, minor_radius=0.025,
                                 location=(0.3, 0.25, 0.35))
ring = bpy.context.active_object
f.inflow_object = ring
ring.keyframe_insert("location", frame=1)
ring.location.y = 0.3
ring.keyframe_insert("location", frame=8)
inputs = in_blender.fluid_inputs(domain)
shapes = [inputs["inflow"][fr] for fr in sorted(inputs["inflow"])]
assert len(shapes) == 8 and all(sh[0] == "mesh" for sh in shapes), [sh[0] for sh in shapes]
assert all(sh[4] is shapes[0][4] for sh in shapes)  # (one field, placed 8 times)
ys = [sh[1][1] for sh in shapes]
assert abs(ys[0] - 0.25) < 1e-5 and abs(ys[-1] - 0.3) < 1e-5 and ys == sorted(ys), ys
f.inflow_object = tap
bpy.data.objects.remove(ring)
# Local Velocity: the velocity turns with the tap (keyed to turn 90 degrees about y over
# frames 1-8: down at frame 1, along -x at 8); off, it is the world's, one for the bake
tap.keyframe_insert("rotation_euler", index=1, frame=1)
tap.rotation_euler.y = math.pi / 2
tap.keyframe_insert("rotation_euler", index=1, frame=8)
for fc in tap.animation_data.action.fcurves:
    for k in fc.keyframe_points:
        k.interpolation = "LINEAR"
f.inflow_local = True
vel = in_blender.fluid_inputs(domain)["inflow_velocity"]
assert sorted(vel) == list(range(1, 9)), vel
assert np.allclose(vel[1], (0, 0, -1), atol=1e-6) and np.allclose(vel[8], (-1, 0, 0), atol=1e-6)
for fr in range(1, 9):  # a unit vector turning from -z towards -x
    a = math.pi / 2 * (fr - 1) / 7
    assert np.allclose(vel[fr], (-math.sin(a), 0, -math.cos(a)), atol=1e-5), (fr, vel[fr])
# baked so (the manifest takes a velocity per frame), then freed
assert bpy.ops.hydrobake.bake(effect="fluid", object_name="Domain") == {"FINISHED"}
assert bpy.ops.hydrobake.free_bake(effect="fluid", object_name="Domain") == {"FINISHED"}
f.inflow_local = False
assert in_blender.fluid_inputs(domain)["inflow_velocity"] == (0.0, 0.0, -1.0)
tap.animation_data_clear()
tap.rotation_euler.y = 0.0
print("FLUID INFLOW FOLLOWED OK")

# refused by name: ending before it starts, outside the domain
f.inflow_start, f.inflow_end = 5, 3
refused("Inflow End = 3 is before Inflow Start = 5")
f.inflow_start, f.inflow_end = 3, 5
tap.location.z = 2.0
refused("Inflow: 'Tap' must overlap the domain's box by at least particle_spacing")
# out of the box at some frames only: it pours nothing there (None), not refused
tap.keyframe_insert("location", index=2, frame=4)
tap.location.z = 0.4
tap.keyframe_insert("location", index=2, frame=5)
inputs = in_blender.fluid_inputs(domain)
assert sorted(inputs["inflow"]) == [1, 3, 5, 6] and inputs["inflow"][3] is None and \
    inputs["inflow"][5][0] == "box", inputs["inflow"]
tap.animation_data_clear()
tap.location.z = 0.4
print("FLUID INFLOW REFUSED OK")

# baked: the particles grow in frames 3-5 only, by the tap's flow, leaving at its velocity
counts, speeds = {}, {}
job = jobs.Job(bpy.context, domain, "fluid")
e = job.runner.effect
counts[1] = e.fluid.particle_count  # (the puddle, before the first step)
old = e.step


def step(frame, progress):
    before = e.fluid.particle_count
    old(frame, progress)
    counts[frame] = e.fluid.particle_count
    speeds[frame] = e.fluid.particles()[1][before:]


e.step = step
job.runner.run()
job.finalize(bpy.context)
grew = {fr: counts[fr] - counts[fr - 1] for fr in range(2, 9)}
assert grew[2] == 0 and grew[6] == 0 and grew[7] == 0 and grew[8] == 0, grew
# (an 8 cm square: 4 x 4 points across, 1 m/s down, 1/24 s a frame, rows a spacing apart;
# frame 3 pours the whole tap at once, 4 x 16, then its face pours)
want = 16 * 1.0 / 24 / s
assert abs(grew[4] + grew[5] - 2 * want) <= 16 and grew[3] >= 64, (grew, want)
print("poured", grew, "a frame of the stream, formula", want)
print("FLUID INFLOW BAKED OK")

# no Fill: the domain starts dry and the tap pours into it from frame 3; frames 1-2 bake an
# empty fluid (no surface, no density) and the bake wires as any other
import glob  # noqa: E402
import os  # noqa: E402
from hydrobake.core import vdb  # noqa: E402
puddle, f.fill_object = f.fill_object, None
f.inflow_start, f.inflow_end = 3, 5
assert bpy.ops.hydrobake.bake(effect="fluid", object_name="Domain") == {"FINISHED"}
folder = bpy.path.abspath(jobs.folder_of(domain, "fluid"))
dens = {fr: vdb.read(glob.glob(os.path.join(folder, f"*fluid_{fr:04d}.vdb"))[0])["density"]
        for fr in (2, 4)}
assert dens[2].activeVoxelCount() == 0 and dens[4].activeVoxelCount() > 0, \
    {fr: d.activeVoxelCount() for fr, d in dens.items()}
faces = {}
for fr in (2, 4):
    bpy.context.scene.frame_set(fr)
    surface = bpy.data.objects["HBK_Domain_surface"]
    faces[fr] = len(surface.evaluated_get(bpy.context.evaluated_depsgraph_get()).data.polygons)
assert faces[2] == 0 and faces[4] > 0, faces
assert bpy.ops.hydrobake.free_bake(effect="fluid", object_name="Domain") == {"FINISHED"}
f.fill_object = None
f.inflow_object = None
refused("Fill: SIMULATE needs an object whose shape the fluid fills (or an Inflow to pour it")
f.fill_object, f.inflow_object = puddle, tap
print("FLUID INFLOW DRY START OK")



def forecast():
    """The bake's forecast of the inflow reaching Max Particles (its warnings that say so)."""
    job = jobs.Job(bpy.context, domain, "fluid")
    try:
        return [w for w in job.warnings if "will stop pouring" in w]
    finally:
        job.runner.effect.close()
        del domain.hydrobake_fluid[jobs.BAKING]


# Max Particles reached: the inflow stops there, the bake says it will before it starts (at
# that frame, give or take one) and that it did when it ends; none is foretold with room to
# spare, nor with an Outflow (however much it drains)
assert forecast() == [], forecast()
f.fluid.max_particles = counts[3] + 20
said = forecast()
assert len(said) == 1 and said[0].startswith("Domain: the inflow will stop pouring at about "
                                             "frame "), said
assert f"it reaches max_particles = {counts[3] + 20} there" in said[0], said
foretold = int(said[0].split("about frame ")[1].split(" ")[0])
f.outflow_object = column
assert forecast() == [], forecast()
f.outflow_object = None
assert bpy.ops.hydrobake.bake(effect="fluid", object_name="Domain") == {"FINISHED"}
job = jobs.Job(bpy.context, domain, "fluid", folder_override=bpy.path.abspath("//capped"))
job.runner.run()
job.finalize(bpy.context)
notes = job.runner.effect.notes()
assert notes == [f"the inflow stopped pouring at frame 4: the fluid holds max_particles = "
                 f"{counts[3] + 20} particles; raise it for more water"], notes
assert abs(foretold - 4) <= 1, (said, notes)
bpy.ops.wm.save_mainfile()  # (the test bakes it again from the command line)
print("FLUID INFLOW CAPPED OK")

# Normal: a sprinkler. The core's inflow_normal is the property (none at 0, as before); a
# ball spraying 1 m/s along its normal and nothing else pours from its surface, out all round
f.fluid.max_particles = 20000
assert "inflow_normal" not in in_blender.fluid_inputs(domain)
f.inflow_object, f.inflow_velocity, f.inflow_normal = ball, (0.0, 0.0, 0.0), 1.0
assert in_blender.fluid_inputs(domain)["inflow_normal"] == 1.0
job = jobs.Job(bpy.context, domain, "fluid", folder_override=bpy.path.abspath("//sprinkler"))
e = job.runner.effect
start, last, old = e.fluid.particle_count, {}, e.step


def step(frame, progress):
    old(frame, progress)
    last["particles"] = e.fluid.particles()


e.step = step
job.runner.run()
job.finalize(bpy.context)
pos, vel = (a[start:] for a in last["particles"])
assert len(pos) > 100, len(pos)
out = pos - np.array(ball.location)
mid = np.linalg.norm(out, axis=1) > 0.05  # (what has left it: not yet in the pool)
moving_out = np.einsum("ij,ij->i", vel[mid], out[mid]) > 0.0
sides = np.sign(out[mid][:, 0])
assert moving_out.mean() > 0.7 and (sides > 0).any() and (sides < 0).any(), \
    (moving_out.mean(), sides)
print("sprinkler:", len(pos), "particles poured,", f"{moving_out.mean():.2f}", "of those out of "
      "it moving away")
print("FLUID INFLOW SPRINKLER OK")

# Keyed Inflow Velocity and Normal: read at every frame (a tap turned up, a sprinkler turned
# on), as the core's inputs by frame; the bake pours each frame at its keyed velocity
f.inflow_object, f.inflow_normal, f.inflow_start, f.inflow_end = ball, 0.0, 1, 8
assert "inflow_normal" not in in_blender.fluid_inputs(domain)


def key(name, values):
    for fr, v in values.items():
        setattr(f, name, v)
        f.keyframe_insert(name, frame=fr)
    for fc in domain.animation_data.action.fcurves:
        if fc.data_path == f.path_from_id(name):
            for k in fc.keyframe_points:
                k.interpolation = "CONSTANT"


key("inflow_normal", {1: 0.0, 4: 1.0})
key("inflow_velocity", {1: (0.0, 0.0, -0.5), 5: (0.0, 0.0, -2.0)})
bpy.context.scene.frame_set(1)
inputs = in_blender.fluid_inputs(domain)
assert inputs["inflow_normal"] == {1: 0.0, 4: 1.0}, inputs["inflow_normal"]
assert inputs["inflow_velocity"] == {1: (0.0, 0.0, -0.5), 5: (0.0, 0.0, -2.0)}, \
    inputs["inflow_velocity"]
# keyed at 0 throughout: no Normal, as unkeyed
fc = next(c for c in domain.animation_data.action.fcurves
          if c.data_path == f.path_from_id("inflow_normal"))
domain.animation_data.action.fcurves.remove(fc)
key("inflow_normal", {1: 0.0, 6: 0.0})
assert "inflow_normal" not in in_blender.fluid_inputs(domain)
job = jobs.Job(bpy.context, domain, "fluid", folder_override=bpy.path.abspath("//keyed"))
e = job.runner.effect
poured, old = {}, e.step


def step(frame, progress):
    before = e.fluid.particle_count
    old(frame, progress)
    poured[frame] = e.fluid.particles()[1][before:]


e.step = step
job.runner.run()
job.finalize(bpy.context)
down = {fr: float(np.median(v[:, 2])) for fr, v in poured.items() if len(v)}
assert -1.2 < down[2] < -0.4 and -2.6 < down[6] < -1.8, down  # (gravity adds up to 0.4 m/s)
print("keyed: median vz of the water poured each frame", down)
print("FLUID INFLOW KEYED OK")
