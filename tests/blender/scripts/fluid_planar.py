"""A planar Inflow (Mantaflow's planar flow): an open mesh such as a Plane pours from the
sheet around its faces, one lattice layer deep, at its area's rate; a flat one's Normal is
one velocity along its face normal (one side only), turning with it; a bent sheet's Normal
sprays both ways and is warned of; an open Outflow drains into its sheet; a bake pours from
a Plane at the forecast rate."""
import math

import bpy
import numpy as np

import in_blender

in_blender.enable()
from hydrobake.blender import jobs  # noqa: E402

in_blender.empty_file("planar.blend")
domain, column, f = in_blender.dam_break((16, 8, 8), frames=(1, 5), substeps=2)
f.fill_object = in_blender.new_box("Puddle", (0.3, 0.5, 0.06), (0.85, 0.25, 0.03))
s = f.fluid.particle_spacing
side = 0.16
bpy.ops.mesh.primitive_plane_add(size=side, location=(0.5, 0.25, 0.4))
plane = bpy.context.active_object
f.inflow_object, f.inflow_velocity, f.inflow_start, f.inflow_end = plane, (0.0, 0.0, -1.0), 1, 5


def inputs_warned():
    """The inputs a bake would take, and the warnings it gives."""
    job = jobs.Job(bpy.context, domain, "fluid")
    try:
        return job.runner.effect.inputs, list(job.warnings)
    finally:
        job.runner.effect.close()
        del domain.hydrobake_fluid[jobs.BAKING]


def job_fluid():
    job = jobs.Job(bpy.context, domain, "fluid")
    return job, job.runner.effect


# the Plane: a sheet (a field negative within half a spacing of its face), not refused as
# thinner than a spacing; in the core one layer of lattice points across it, pouring its
# area's columns at 1 m/s
inputs, said = inputs_warned()
sheet = inputs["inflow"][1]
assert sheet[0] == "mesh" and sheet[4].min() < 0.0, sheet[:4]
assert not [w for w in said if "Inflow" in w], said
assert inputs["inflow_velocity"] == (0.0, 0.0, -1.0), inputs["inflow_velocity"]
job, e = job_fluid()
try:
    e.fluid.set_inflow(sheet, (0.0, 0.0, -1.0))
    points, rate = e.fluid.inflow_points, e.fluid.inflow_rate
    columns = rate * s / 1.0
    assert (side / s) ** 2 * 0.9 < columns < ((side + s) / s) ** 2 * 1.1, (columns, side / s)
    assert points <= 2.05 * columns, (points, columns)  # one layer or two, not a slab
    e.fluid.set_inflow(None)
finally:
    e.close()
    del domain.hydrobake_fluid[jobs.BAKING]
print("planar:", points, "points,", f"{columns:.0f}", "columns for", f"{(side / s) ** 2:.0f}",
      "spacing squares of plane")
print("FLUID PLANAR SHEET OK")

# Normal on a flat sheet: one velocity along its face normal (+z for a Plane), added to the
# Inflow Velocity, and turned with it; no inflow_normal (no sprinkler)
f.inflow_velocity, f.inflow_normal = (0.5, 0.0, 0.0), 1.0
inputs = in_blender.fluid_inputs(domain)
assert "inflow_normal" not in inputs, inputs.get("inflow_normal")
assert np.allclose(inputs["inflow_velocity"], (0.5, 0.0, 1.0), atol=1e-6), \
    inputs["inflow_velocity"]
plane.rotation_euler = (math.pi, 0.0, 0.0)  # upside down: it pours downward
inputs = in_blender.fluid_inputs(domain)
assert np.allclose(inputs["inflow_velocity"], (0.5, 0.0, -1.0), atol=1e-6), \
    inputs["inflow_velocity"]
plane.rotation_euler = (0.0, 0.0, 0.0)
# keyed turning: the velocity follows the plane frame by frame
plane.keyframe_insert("rotation_euler", frame=1)
plane.rotation_euler = (math.pi / 2, 0.0, 0.0)
plane.keyframe_insert("rotation_euler", frame=3)
for fc in plane.animation_data.action.fcurves:
    for k in fc.keyframe_points:
        k.interpolation = "CONSTANT"
bpy.context.scene.frame_set(1)
v = in_blender.fluid_inputs(domain)["inflow_velocity"]
assert sorted(v) == [1, 3] and np.allclose(v[1], (0.5, 0.0, 1.0), atol=1e-6) and \
    np.allclose(v[3], (0.5, -1.0, 0.0), atol=1e-6), v
plane.animation_data_clear()
plane.rotation_euler = (0.0, 0.0, 0.0)
print("FLUID PLANAR NORMAL OK")

# a bent sheet (the plane subdivided, its middle raised): its Normal sprays both ways, said
bpy.ops.mesh.primitive_grid_add(x_subdivisions=4, y_subdivisions=4, size=side,
                                location=(0.5, 0.25, 0.4))
bent = bpy.context.active_object
for vtx in bent.data.vertices:
    vtx.co.z = 0.05 * (1.0 - (vtx.co.x ** 2 + vtx.co.y ** 2) / (side / 2) ** 2)
f.inflow_object = bent
inputs, said = inputs_warned()
assert inputs["inflow"][1][0] == "mesh" and inputs["inflow_normal"] == 1.0, inputs.get(
    "inflow_normal")
assert inputs["inflow_velocity"] == (0.5, 0.0, 0.0), inputs["inflow_velocity"]
assert any(f"Inflow: {bent.name}'s faces are open and do not lie in one plane" in w
           for w in said), said
f.inflow_object, f.inflow_normal = plane, 0.0
print("FLUID PLANAR BENT OK")

# an open Outflow: the sheet around its faces drains
f.outflow_object = bent
inputs = in_blender.fluid_inputs(domain)
assert inputs["outflow"][1][0] == "mesh" and inputs["outflow"][1][4].min() < 0.0
f.outflow_object = None
print("FLUID PLANAR OUTFLOW OK")

# a bake pours from the Plane: frames 2-5 add about its rate x time (the water falls clear)
f.inflow_velocity = (0.0, 0.0, -1.0)
job = jobs.Job(bpy.context, domain, "fluid", folder_override=bpy.path.abspath("//planar"))
e = job.runner.effect
counts, old = {}, e.step


def step(frame, progress):
    old(frame, progress)
    counts[frame] = e.fluid.particle_count


e.step = step
job.runner.run()
job.finalize(bpy.context)
poured = counts[5] - counts[1]
want = rate * 4 * e.params["fluid"].dt
assert 0.75 * want < poured < 1.25 * want, (poured, want)
print("planar bake:", poured, "poured in frames 2-5 against", f"{want:.0f}", "forecast")
print("FLUID PLANAR BAKED OK")
