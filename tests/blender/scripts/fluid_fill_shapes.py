"""The Fill object's shape: a UV sphere's water is a ball (as many particles as its volume
holds lattice cells, all inside it), a torus fills its tube and leaves the hole dry, a
metaball family's member fills the family's one surface, a box is its box as before, and an
open mesh (no inside) fills its box with a warning, and so does a ball not in the scene (its
shape cannot be read; a box says nothing). The Initial Velocity is every particle's at the
start, with Source the Fill object's own motion over the first frame added. A thrown ball of
water bakes through the operator."""
import bpy
import numpy as np

import in_blender

in_blender.enable()
from hydrobake.blender import jobs  # noqa: E402

in_blender.empty_file("fill.blend")
domain, column, f = in_blender.dam_break((16, 8, 8), frames=(1, 3), substeps=2)
s = f.fluid.particle_spacing
velocities = None  # the last filled()'s


def filled(obj):
    """The fill shape a bake would take from ``obj``, its particles, and the warnings."""
    f.fill_object = obj
    job = jobs.Job(bpy.context, domain, "fluid")
    try:
        e = job.runner.effect
        global velocities
        pos, velocities = e.fluid.particles()
        return e.inputs.get("fill_shape"), pos, list(job.warnings)
    finally:
        job.runner.effect.close()
        del domain.hydrobake_fluid[jobs.BAKING]


def added(op, **kw):
    op(**kw)
    return bpy.context.active_object


# a box: its box, as before
shape, pos, _ = filled(column)
assert shape is None and len(pos) > 0
assert np.all(pos > (0.025, 0.025, 0.0)) and np.all(pos < (0.275, 0.475, 0.41)), \
    (pos.min(0), pos.max(0))
print("FLUID FILL BOX OK")

# a ball: 4/3 pi r^3 of water, all inside
ball = added(bpy.ops.mesh.primitive_uv_sphere_add, radius=0.12, location=(0.3, 0.25, 0.25))
shape, pos, _ = filled(ball)
assert shape[0] == "sphere" and abs(shape[2] - 0.12) < 1e-3, shape
assert abs(len(pos) * s ** 3 / (4 / 3 * np.pi * 0.12 ** 3) - 1.0) < 0.05, len(pos)
assert np.linalg.norm(pos - (0.3, 0.25, 0.25), axis=1).max() < 0.12
print("FLUID FILL BALL OK")

# a torus lying flat: its tube's volume, the hole dry
ring = added(bpy.ops.mesh.primitive_torus_add, major_radius=0.15, minor_radius=0.06,
             location=(0.5, 0.25, 0.2))
shape, pos, _ = filled(ring)
assert shape[0] == "mesh", shape[0]
assert abs(len(pos) * s ** 3 / (2 * np.pi ** 2 * 0.15 * 0.06 ** 2) - 1.0) < 0.08, len(pos)
axis = np.hypot(pos[:, 0] - 0.5, pos[:, 1] - 0.25)
assert axis.min() > 0.15 - 0.06 - 0.005 and axis.max() < 0.15 + 0.06 + 0.005, \
    (axis.min(), axis.max())
print("FLUID FILL TORUS OK")

# a metaball family's member: the family's surface (its own box is empty)
drops = []
for x in (0.3, 0.6):
    drops.append(added(bpy.ops.object.metaball_add, type="BALL", radius=0.2,
                       location=(x, 0.25, 0.25)))
drops[0].name, drops[1].name = "Drop", "Drop.001"
shape, pos, _ = filled(drops[1])
assert shape[0] == "mesh", shape[0]
near = [np.linalg.norm(pos - (x, 0.25, 0.25), axis=1).min() for x in (0.3, 0.6)]
assert max(near) < 0.03 and len(pos) > 200, (near, len(pos))
for o in drops:
    bpy.data.objects.remove(o)
print("FLUID FILL METABALLS OK")

# an open cone (no caps): no inside, so its box, and a warning that says so
cone = added(bpy.ops.mesh.primitive_cone_add, radius1=0.1, depth=0.2, end_fill_type="NOTHING",
             location=(0.7, 0.25, 0.15))
shape, pos, warned = filled(cone)
assert shape is None and len(pos) > 0
assert [w for w in warned if "Fill: Cone's faces do not all face out" in w], warned
print("FLUID FILL OPEN OK")

# not in the scene (appended beside the domain, say): its box, as before shapes were read;
# said of a ball, not of a box
held = {o: list(o.users_collection) for o in (ball, column)}
for o, colls in held.items():
    for c in colls:
        c.objects.unlink(o)
shape, pos, warned = filled(column)
assert shape is None and len(pos) > 0 and not [w for w in warned if "Fill" in w], warned
shape, pos, warned = filled(ball)
assert shape is None and len(pos) * s ** 3 > 0.2 ** 3, len(pos)  # (the ball's 0.24 m box)
assert [w for w in warned if "Fill: 'Sphere' is not evaluated" in w and
        "its shape cannot be read" in w], warned
for o, colls in held.items():
    for c in colls:
        c.objects.link(o)
print("FLUID FILL UNEVALUATED OK")

# thrown: every particle starts with the Initial Velocity
f.fill_velocity = (1.5, 0.0, 0.5)
shape, pos, _ = filled(ball)
assert len(pos) > 0 and np.all(velocities == np.float32((1.5, 0.0, 0.5))), velocities[:3]
# keyed to fly (10 cm along x and 5 up over the first frame, 1/24 s): with Source its water
# flies on with it, (2.4, 0, 1.2) m/s added (half at 0.5); at 0 only the Initial Velocity
start = tuple(ball.location)
for frame, move in ((1, (0.0, 0.0, 0.0)), (2, (0.1, 0.0, 0.05))):
    ball.location = np.add(start, move)
    ball.keyframe_insert("location", frame=frame)
for fc in ball.animation_data.action.fcurves:
    for k in fc.keyframe_points:
        k.interpolation = "LINEAR"
bpy.context.scene.frame_set(1)
for source, want in ((1.0, (3.9, 0.0, 1.7)), (0.5, (2.7, 0.0, 1.1)), (0.0, (1.5, 0.0, 0.5))):
    f.fill_source = source
    shape, pos, _ = filled(ball)
    assert np.allclose(shape[1], start, atol=1e-5), (shape[1], start)  # (its place at frame 1)
    assert np.allclose(velocities, want, atol=1e-3), (source, velocities[:3])
f.fill_source = 1.0
ball.animation_data_clear()
ball.location = start
print("FLUID FILL THROWN OK")

# baked through the operator
f.fill_object = ball
assert bpy.ops.hydrobake.bake(effect="fluid", object_name="Domain") == {"FINISHED"}
print("FLUID FILL BAKED OK")
