"""Several inflows: every object of the Inflows collection pours as the Inflow does, from its
own shape (the core's inflow a list of schedules, one per tap), Local Velocity turning each
with its own axes; the Inflow and a collection holding it pour it once; a collection of one
is the Inflow's single input; a tap outside the domain is refused by name; a bake pours from
every tap."""
import math

import bpy
import numpy as np

import in_blender

in_blender.enable()
from hydrobake.blender import jobs  # noqa: E402

in_blender.empty_file("inflows.blend")
domain, column, f = in_blender.dam_break((16, 8, 8), frames=(1, 4), substeps=2)
f.fill_object = in_blender.new_box("Puddle", (0.3, 0.5, 0.06), (0.85, 0.25, 0.03))
taps = bpy.data.collections.new("Taps")
bpy.context.scene.collection.children.link(taps)
left = in_blender.new_box("Left", (0.06, 0.06, 0.06), (0.25, 0.15, 0.4))
right = in_blender.new_box("Right", (0.06, 0.06, 0.06), (0.65, 0.35, 0.4))
for o in (left, right):
    taps.objects.link(o)
f.inflow_object, f.inflow_collection = None, taps
f.inflow_velocity, f.inflow_start, f.inflow_end = (0.0, 0.0, -1.0), 1, 4

inputs = in_blender.fluid_inputs(domain)
flows = inputs["inflow"]
assert isinstance(flows, list) and len(flows) == 2, flows
centres = [sorted(fl.items())[0][1][1] for fl in flows]
assert np.allclose(centres, [(0.25, 0.15, 0.4), (0.65, 0.35, 0.4)]), centres
assert inputs["inflow_velocity"] == [(0.0, 0.0, -1.0)] * 2, inputs["inflow_velocity"]
assert "inflow_normal" not in inputs
# Local Velocity: each tap's own axes turn its velocity
right.rotation_euler = (0.0, math.pi / 2, 0.0)
f.inflow_local = True
v = in_blender.fluid_inputs(domain)["inflow_velocity"]
assert np.allclose(v[0], (0.0, 0.0, -1.0)) and np.allclose(v[1], (-1.0, 0.0, 0.0), atol=1e-6), v
right.rotation_euler = (0.0, 0.0, 0.0)
f.inflow_local = False
print("FLUID INFLOWS INPUTS OK")

# the Inflow and a collection holding it: it pours once; a collection of one is the Inflow
f.inflow_object = left
assert len(in_blender.fluid_inputs(domain)["inflow"]) == 2
taps.objects.unlink(right)
f.inflow_object = None
one = in_blender.fluid_inputs(domain)
assert isinstance(one["inflow"], dict) and one["inflow_velocity"] == (0.0, 0.0, -1.0), one
taps.objects.link(right)
# a tap outside the domain at every frame: refused by name
far = in_blender.new_box("Far", (0.06, 0.06, 0.06), (3.0, 3.0, 3.0))
taps.objects.link(far)
in_blender.inputs_refused(domain, "fluid", "Inflow: 'Far' must overlap the domain's box")
taps.objects.unlink(far)
print("FLUID INFLOWS ONCE OK")

# a bake pours from both taps: new water under each
job = jobs.Job(bpy.context, domain, "fluid", folder_override=bpy.path.abspath("//taps"))
e = job.runner.effect
start, last, old = e.fluid.particle_count, {}, e.step


def step(frame, progress):
    old(frame, progress)
    last["pos"] = e.fluid.particles()[0]


e.step = step
job.runner.run()
job.finalize(bpy.context)
pos = last["pos"][start:]
under = [np.sum(np.all(np.abs(pos[:, :2] - c[:2]) < 0.06, axis=1)) for c in centres]
assert len(pos) > 0 and all(n > 0.3 * len(pos) for n in under), (len(pos), under)
print("inflows: poured", len(pos), "particles,", under, "under each tap")
print("FLUID INFLOWS BAKED OK")

# several drains: every object of the Outflows collection drains its own shape; after the
# bake no water is inside either, though the taps pour onto both
drains = bpy.data.collections.new("Drains")
bpy.context.scene.collection.children.link(drains)
boxes = [in_blender.new_box(n, (0.2, 0.2, 0.06), (x, y, 0.03))
         for n, x, y in (("DrainL", 0.25, 0.15), ("DrainR", 0.65, 0.35))]
for o in boxes:
    drains.objects.link(o)
f.outflow_collection = drains
outs = in_blender.fluid_inputs(domain)["outflow"]
assert isinstance(outs, list) and len(outs) == 2, outs
f.outflow_object = boxes[0]  # (the Outflow and in the collection: once)
assert len(in_blender.fluid_inputs(domain)["outflow"]) == 2


def bake_inside(folder):
    """(particles drained by frame, those inside each drain's box at the end) of a bake."""
    job = jobs.Job(bpy.context, domain, "fluid", folder_override=bpy.path.abspath(folder))
    e = job.runner.effect
    removed, last, old = [], {}, e.step

    def step(frame, progress):
        old(frame, progress)
        removed.append(e.fluid.outflow_removed)
        last["pos"] = e.fluid.particles()[0]
    e.step = step
    job.runner.run()
    job.finalize(bpy.context)
    pos = last["pos"]
    return removed, [int(np.sum(np.all(np.abs(pos - np.array(o.location)) <
                                       np.array([0.1, 0.1, 0.03]), axis=1))) for o in boxes]


removed, inside = bake_inside("//drains")
assert sum(removed) > 0 and inside == [0, 0], (removed, inside)
# (the left drain alone leaves water in the right one's box: both drained above)
drains.objects.unlink(boxes[1])
_, alone = bake_inside("//drain")
assert alone[0] == 0 and alone[1] > 0, alone
drains.objects.link(boxes[1])
print("outflows: drained", removed, "particles by frame; none left inside either (the left "
      "alone leaves", alone[1], "in the right one's box)")
print("FLUID OUTFLOWS BAKED OK")
