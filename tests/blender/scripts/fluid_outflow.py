"""The Outflow object, a drain: its shape is the core's outflow input (a box clipped to the
domain, a ball as a sphere, a ring by its field), followed where it moves; one outside the
domain at every frame is refused by name, and one keyed into it at a frame (a plug pulled)
drains from that frame, and so does one with Outflow Start at that frame (End before Start is
refused). Baked: no water is left inside it at any frame's end, the water it took is the water
missing, it takes none outside its Start and End, and a tap that would stop at Max Particles
pours for good into it."""
import bpy
import numpy as np

import in_blender

in_blender.enable()
from hydrobake.blender import jobs  # noqa: E402

in_blender.empty_file("outflow.blend")
domain, column, f = in_blender.dam_break((16, 8, 8), frames=(1, 8), substeps=2)
# the floor's right 30 cm, from 5 cm below the domain to 5 cm into it
drain = in_blender.new_box("Drain", (0.3, 0.5, 0.1), (0.85, 0.25, 0.0))
f.outflow_object = drain


def refused(text):
    in_blender.inputs_refused(domain, "fluid", text)


# a box drain: its box within the domain, at every frame (it does not move)
inputs = in_blender.fluid_inputs(domain)
assert sorted(inputs["outflow"]) == [1], inputs["outflow"]
kind, centre, half = inputs["outflow"][1]
assert kind == "box" and np.allclose(centre, (0.85, 0.25, 0.025)) and \
    np.allclose(half, (0.15, 0.25, 0.025)), inputs["outflow"]
# a ball drains as a sphere; a ring (a mesh: its field) keyed to move is followed
bpy.ops.mesh.primitive_uv_sphere_add(radius=0.05, location=(0.8, 0.25, 0.05))
ball = bpy.context.active_object
f.outflow_object = ball
inputs = in_blender.fluid_inputs(domain)
assert inputs["outflow"][1][0] == "sphere" and abs(inputs["outflow"][1][2] - 0.05) < 1e-3, \
    inputs["outflow"]
bpy.ops.mesh.primitive_torus_add(major_radius=0.06, minor_radius=0.025,
                                 location=(0.8, 0.25, 0.05))
ring = bpy.context.active_object
f.outflow_object = ring
ring.keyframe_insert("location", frame=1)
ring.location.x = 0.6
ring.keyframe_insert("location", frame=8)
inputs = in_blender.fluid_inputs(domain)
shapes = [inputs["outflow"][fr] for fr in sorted(inputs["outflow"])]
assert sorted(inputs["outflow"]) == list(range(1, 9)), sorted(inputs["outflow"])
assert all(sh[0] == "mesh" and sh[4] is shapes[0][4] for sh in shapes)  # one field, placed
xs = [sh[1][0] for sh in shapes]
assert abs(xs[0] - 0.8) < 1e-5 and abs(xs[-1] - 0.6) < 1e-5 and xs == sorted(xs)[::-1], xs
print("FLUID OUTFLOW INPUTS OK")

# refused by name: outside the domain at every frame
f.outflow_object = drain
drain.location.z = -0.5
refused("Outflow: 'Drain' must overlap the domain's box by at least particle_spacing")
# a plug pulled at frame 4: keyed from below the domain into it, it drains from frame 4 on
drain.keyframe_insert("location", index=2, frame=3)
drain.location.z = 0.0
drain.keyframe_insert("location", index=2, frame=4)
for k in drain.animation_data.action.fcurves[0].keyframe_points:
    k.interpolation = "CONSTANT"
flow = in_blender.fluid_inputs(domain)["outflow"]
assert sorted(flow) == [1, 4] and flow[1] is None and flow[4][0] == "box", flow
drain.animation_data_clear()
drain.location.z = 0.0
# the same by Outflow Start and End: it drains in frames 4-6 only; End before Start is refused
f.outflow_start, f.outflow_end = 4, 6
flow = in_blender.fluid_inputs(domain)["outflow"]
assert sorted(flow) == [1, 4, 7] and flow[1] is None and flow[4][0] == "box" and \
    flow[7] is None, flow
f.outflow_start, f.outflow_end = 6, 4
refused("Outflow End = 4 is before Outflow Start = 6: the Outflow would never drain")
f.outflow_start, f.outflow_end = 1, 250
drawn = [a[1] for n, a, _k in in_blender.panel_calls(domain, "fluid") if n == "prop"]
assert "outflow_start" in drawn and "outflow_end" in drawn, drawn
print("FLUID OUTFLOW REFUSED OK")


def bake(folder):
    """Frames 1-8 baked into ``folder``: the particles at each frame's end, what the drain
    took in each frame, and the effect's notes."""
    job = jobs.Job(bpy.context, domain, "fluid", folder_override=bpy.path.abspath(folder))
    e = job.runner.effect
    start, old = e.fluid.particle_count, e.step
    pos, took = {}, {}

    def step(frame, progress):
        old(frame, progress)
        pos[frame] = e.fluid.particles()[0]
        took[frame] = e.fluid.outflow_removed
    e.step = step
    job.runner.run()
    job.finalize(bpy.context)
    return start, pos, took, e.notes()


# the dam break's front runs into the drain: none is left inside it at a frame's end, and
# what it took is what is missing
start, pos, took, _ = bake("//drained")
for fr, p in pos.items():
    inside = (p[:, 0] > 0.7) & (p[:, 2] < 0.05)
    assert not inside.any(), (fr, p[inside][:5])
assert sum(took.values()) == start - len(pos[8]) and sum(took.values()) > 50, (start, took)
assert took[1] == 0, took  # (the column starts far from it)
print("drained", took, "of", start)
# open from frame 2 to 7 (Outflow Start and End; the front reaches it in frame 7): it takes
# water then, and none in frame 8, when the water stays in it; what it took is still what is
# missing
f.outflow_start, f.outflow_end = 2, 7
start, pos, timed, _ = bake("//timed")
assert timed[7] > 0 and timed[8] == 0, timed
inside = {fr: int(((p[:, 0] > 0.7) & (p[:, 2] < 0.05)).sum()) for fr, p in pos.items()}
assert inside[7] == 0 and inside[8] > 0, inside  # (open, closed)
assert sum(timed.values()) == start - len(pos[8]), (start, timed)
f.outflow_start, f.outflow_end = 1, 250
print("FLUID OUTFLOW BAKED OK")

# a tap over the drain: without it, the bake stops pouring at Max Particles; with it, it
# pours for good
tap = in_blender.new_box("Tap", (0.08, 0.08, 0.08), (0.85, 0.25, 0.3))
f.inflow_object, f.inflow_velocity, f.inflow_start, f.inflow_end = tap, (0, 0, -1), 1, 8
f.fluid.max_particles = start + 200
f.outflow_object = None
_, pos, _, notes = bake("//capped")
assert len(pos[8]) == start + 200 and notes and "stopped pouring" in notes[0], notes
f.outflow_object = drain
_, pos, took, notes = bake("//tapped")
assert notes == [] and len(pos[8]) < start + 200, (notes, len(pos[8]))
print("FLUID OUTFLOW TAP OK")
