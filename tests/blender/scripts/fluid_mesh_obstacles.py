"""Mesh obstacles: a torus in the Obstacles collection is its shape (a distance field made
at the first frame: negative in its tube, positive in its hole, in metres along its own axes),
and the dam break's water falls through its hole, where its box (what the addon took before)
would have held it all; keyed to move, it is carried with its field (kept, not read again);
flipped normals are turned out, an open mesh is a thin shell (named in a warning); a cube
stays a box, and a mesh that deforms gets a field of its own at every frame."""
import bpy
import numpy as np

import in_blender

in_blender.enable()
from hydrobake.blender import jobs  # noqa: E402
from hydrobake.blender.bridge import mesh_fields  # noqa: E402

in_blender.empty_file("ring.blend")
scene = bpy.context.scene
bpy.ops.mesh.primitive_torus_add(major_radius=0.12, minor_radius=0.04, location=(0.3, 0.3, 0.25),
                                 rotation=(0.15, 0.0, 0.0))
ring = bpy.context.active_object
ring.scale = (1.2, 1.2, 1.0)
rings = bpy.data.collections.new("Rings")
scene.collection.children.link(rings)
rings.objects.link(ring)
domain = in_blender.ring_drop(rings)
scene.frame_set(1)


(kind, c, e, q, field), = in_blender.fluid_inputs(domain)["obstacles"]
assert kind == "mesh" and field.ndim == 3 and max(field.shape) <= 128, (kind, field.shape)
assert np.allclose(c, (0.3, 0.3, 0.25), atol=2e-3), c
rq = ring.matrix_world.to_quaternion()
assert np.allclose(q, (rq.w, rq.x, rq.y, rq.z), atol=1e-6), q
# its own axes, scaled: the tube 0.04 thick, the ring 0.144 across; at its points (corners
# included): in the tube's core about -0.04, in the middle of the hole 0.144 - 0.048
zs, ys, xs = (np.linspace(-h, h, n) for h, n in zip(e[::-1], field.shape))
k, j = np.argmin(np.abs(zs)), np.argmin(np.abs(ys))
i_core, i_hole = np.argmin(np.abs(xs - 0.144)), np.argmin(np.abs(xs))
assert abs(field[k, j, i_core] + 0.04) < 0.01, field[k, j, i_core]
assert abs(field[k, j, i_hole] - (0.144 - 0.048)) < 0.01, field[k, j, i_hole]
print("FLUID MESH FIELD OK")


through = in_blender.water_under_hole(domain)
shape = mesh_fields.mesh_shape
mesh_fields.mesh_shape = lambda *a: None  # the addon before: the ring its box
try:
    held = in_blender.water_under_hole(domain)
finally:
    mesh_fields.mesh_shape = shape
print("water under the hole: as a mesh", through, "as its box", held)
assert through > 300.0 and held < 1.0, (through, held)
print("FLUID MESH RING OK")

# Keyed to slide along x: carried with the first frame's field.
ring.keyframe_insert("location", index=0, frame=1)
ring.location.x = 0.4
ring.keyframe_insert("location", index=0, frame=9)
for kp in ring.animation_data.action.fcurves[0].keyframe_points:
    kp.interpolation = "LINEAR"
scene.frame_set(1)
inp = in_blender.fluid_inputs(domain)
assert inp["obstacles"][0][0] == "mesh" and inp["obstacles"][0][4] is not None
path = inp["obstacle_path"]
assert sorted(path) == list(range(2, 10)), sorted(path)
for frame, ((kind, c, e2, q2, fld),) in path.items():
    assert kind == "mesh" and fld is None, (kind, fld)
    assert abs(c[0] - (0.3 + 0.1 * (frame - 1) / 8)) < 2e-3 and np.allclose(e2, e), (frame, c)
assert bpy.ops.hydrobake.bake(effect="fluid", object_name="Domain") == {"FINISHED"}
assert bpy.ops.hydrobake.free_bake(effect="fluid", object_name="Domain") == {"FINISHED"}
print("FLUID MESH MOVING OK")

# Its normals flipped (all facing in): the same field. Open (a face gone) or with normals
# that disagree: a thin shell, unsigned, and a warning names it. A reading step of its own,
# named: "the shape of Torus (1/1)".
import bmesh  # noqa: E402
from hydrobake.blender.reading_progress import step_text  # noqa: E402


def job_of():
    job = jobs.Job(bpy.context, domain, "fluid")
    job.runner.effect.close()
    del domain.hydrobake_fluid[jobs.BAKING]
    return job.runner.effect.inputs, job.warnings


def edit(fn):
    bm = bmesh.new()
    bm.from_mesh(ring.data)
    bm.faces.ensure_lookup_table()
    fn(bm)
    bm.to_mesh(ring.data)
    bm.free()
    ring.data.update()


ring.animation_data_clear()
ring.location.x = 0.3
scene.frame_set(1)
edit(lambda bm: bmesh.ops.reverse_faces(bm, faces=bm.faces))
inp, warned = job_of()
assert not [w for w in warned if "face out" in w], warned
flipped = inp["obstacles"][0][4]  # (the quads cut along the other diagonal: a hair apart)
assert np.abs(flipped - field).max() < 2e-3, np.abs(flipped - field).max()
assert np.array_equal(np.sign(flipped[np.abs(field) > 2e-3]),
                      np.sign(field[np.abs(field) > 2e-3]))
edit(lambda bm: bmesh.ops.reverse_faces(bm, faces=list(bm.faces)[:40]))
inp, warned = job_of()
assert [w for w in warned if w.startswith("Obstacles: Torus's faces do not all face out")], warned
assert inp["obstacles"][0][0] == "mesh" and inp["obstacles"][0][4].min() >= 0.0
edit(lambda bm: bmesh.ops.reverse_faces(bm, faces=list(bm.faces)[:40]))
edit(lambda bm: bmesh.ops.delete(bm, geom=[bm.faces[0]], context="FACES_ONLY"))
inp, warned = job_of()
assert [w for w in warned if "do not all face out" in w], warned
assert inp["obstacles"][0][4].min() >= 0.0
reading = jobs.Job.stepwise(bpy.context, domain, "fluid")
try:
    steps = []
    while reading.step() is not None:
        steps.append(step_text(*reading.last))
finally:
    reading.close()
    if reading.job.__dict__.get("runner") is not None:
        reading.job.runner.effect.close()
    domain.hydrobake_fluid.pop(jobs.BAKING, None)
assert "the shape of Torus (1/1)" in steps, steps
print("FLUID MESH NORMALS OK")

# A cube is a box, a cylinder its shape; a torus under a Wave modifier (its shape changes) is its shape made again
# at every frame, each a field of its own of one count of points, and it bakes.
ring.modifiers.new("Wave", "WAVE").height = 0.05
in_blender_cube = in_blender.new_box("Cube", (0.1, 0.1, 0.1), (0.1, 0.1, 0.1))
rings.objects.link(in_blender_cube)
# a cylinder's vertices all lie on one sphere, but it is no ball: its shape
bpy.ops.mesh.primitive_cylinder_add(vertices=24, radius=0.05, depth=0.04,
                                    location=(0.5, 0.1, 0.05))
can = bpy.context.active_object
for coll in list(can.users_collection):
    coll.objects.unlink(can)
rings.objects.link(can)
scene.frame_set(1)
inp = in_blender.fluid_inputs(domain)
at = {o.name: k for k, o in enumerate(rings.all_objects)}
assert inp["obstacles"][at["Cube"]][0] == "box", inp["obstacles"][at["Cube"]][0]
assert inp["obstacles"][at[can.name]][0] == "mesh", inp["obstacles"][at[can.name]][0]
waved = inp["obstacles"][at["Torus"]]
assert waved[0] == "mesh" and waved[4].ndim == 3, waved[0]
fields = [waved[4]] + [obs[at["Torus"]][4] for _, obs in sorted(inp["obstacle_path"].items())]
assert len(fields) == 9 and all(f is not None for f in fields), len(fields)
assert not any(np.array_equal(a, b) for a, b in zip(fields, fields[1:])), "the same shapes"
# one count of points for all of them, so that each step changes one into the next, over
# each frame's own box
assert len({f.shape for f in fields}) == 1, {f.shape for f in fields}
assert bpy.ops.hydrobake.bake(effect="fluid", object_name="Domain") == {"FINISHED"}
assert bpy.ops.hydrobake.free_bake(effect="fluid", object_name="Domain") == {"FINISHED"}
# A shape that walks off along x within its mesh (a shape key, as an armature's root would):
# each frame's field over that frame's shape, not one box holding the whole walk.
bpy.ops.mesh.primitive_torus_add(major_radius=0.05, minor_radius=0.02, location=(0.2, 0.4, 0.1))
walker = bpy.context.active_object
for coll in list(walker.users_collection):
    coll.objects.unlink(walker)
rings.objects.link(walker)
walker.shape_key_add(name="Basis")
off = walker.shape_key_add(name="Off")
for v in off.data:
    v.co.x += 0.2
for frame, value in ((1, 0.0), (9, 1.0)):
    off.value = value
    off.keyframe_insert("value", frame=frame)
scene.frame_set(1)
inp = in_blender.fluid_inputs(domain)
at = {o.name: k for k, o in enumerate(rings.all_objects)}
walk = [inp["obstacles"][at[walker.name]]] + [
    obs[at[walker.name]] for _, obs in sorted(inp["obstacle_path"].items())]
assert len({w[4].shape for w in walk}) == 1, {w[4].shape for w in walk}
assert all(np.allclose(w[2], walk[0][2], atol=1e-4) for w in walk), [w[2] for w in walk]
assert abs(walk[-1][1][0] - walk[0][1][0] - 0.2) < 1e-3, (walk[0][1], walk[-1][1])
print("FLUID MESH BOXES OK")
