"""Curves, texts and metaballs as the fluid's obstacles: each is the mesh Blender evaluates it
to, made a distance field as a mesh is. A bevelled circle is a ring the dam break's water
falls through (its box, what the addon took before, held it all); a curve without bevel is
its box; a text with depth and a metaball are their shapes; a keyed bevel changes the
curve's shape, so it gets a field at every frame. Metaballs named alike melt into one
surface, which only the first of them (the basis) evaluates to: any of them in Obstacles is
that surface, the family one obstacle, and a member that moves changes its shape."""
import bpy
import numpy as np

import in_blender

in_blender.enable()

in_blender.empty_file("curves.blend")
scene = bpy.context.scene
bpy.ops.curve.primitive_bezier_circle_add(radius=0.12, location=(0.3, 0.3, 0.25))
ring = bpy.context.active_object
ring.data.bevel_depth = 0.04
holders = bpy.data.collections.new("Holders")
scene.collection.children.link(holders)
holders.objects.link(ring)
domain = in_blender.ring_drop(holders)
scene.frame_set(1)

(kind, c, e, q, field), = in_blender.fluid_inputs(domain)["obstacles"]
assert kind == "mesh" and field.ndim == 3, kind
assert np.allclose(c, (0.3, 0.3, 0.25), atol=3e-3), c
# its own axes: in the tube's core about -0.04 (the bevel), in the middle of the hole 0.08
zs, ys, xs = (np.linspace(-h, h, n) for h, n in zip(e[::-1], field.shape))
k, j = np.argmin(np.abs(zs)), np.argmin(np.abs(ys))
i_core, i_hole = np.argmin(np.abs(xs - 0.12)), np.argmin(np.abs(xs))
assert abs(field[k, j, i_core] + 0.04) < 0.01, field[k, j, i_core]
assert abs(field[k, j, i_hole] - 0.08) < 0.01, field[k, j, i_hole]
print("FLUID CURVE FIELD OK")

most = in_blender.water_under_hole(domain)
print("water under the bevelled circle's hole:", most)
assert most > 300.0, most  # (its box: 0, fluid_mesh_obstacles.py)
print("FLUID CURVE RING OK")

# Without bevel, a curve has no faces: its box. A text with depth and a metaball capsule:
# their shapes.
ring.data.bevel_depth = 0.0
bpy.ops.object.text_add(location=(0.15, 0.15, 0.05))
text = bpy.context.active_object
text.data.body, text.data.extrude, text.data.size = "HB", 0.02, 0.1
bpy.ops.object.metaball_add(type="CAPSULE", radius=0.05, location=(0.45, 0.45, 0.1))
blob = bpy.context.active_object
for o in (text, blob):
    for coll in list(o.users_collection):
        coll.objects.unlink(o)
    holders.objects.link(o)
scene.frame_set(1)
at = {o.name: k for k, o in enumerate(holders.all_objects)}
obs = in_blender.fluid_inputs(domain)["obstacles"]
assert obs[at[ring.name]][0] == "box", obs[at[ring.name]][0]
for o in (text, blob):
    got = obs[at[o.name]]
    assert got[0] == "mesh" and got[4].min() < 0.0 < got[4].max(), (o.name, got[0])
    assert np.allclose(got[1], (np.array(o.matrix_world) @ np.append(
        np.mean(np.array([v[:] for v in o.bound_box]), axis=0), 1.0))[:3], atol=0.02), got[1]
print("FLUID CURVE KINDS OK")

# A keyed bevel: the curve's shape changes, a field at every frame.
for o in (text, blob):
    bpy.data.objects.remove(o)
ring.data.bevel_depth = 0.02
ring.data.keyframe_insert("bevel_depth", frame=1)
ring.data.bevel_depth = 0.05
ring.data.keyframe_insert("bevel_depth", frame=9)
scene.frame_set(1)
inp = in_blender.fluid_inputs(domain)
fields = [inp["obstacles"][0][4]] + [o[0][4] for _, o in sorted(inp["obstacle_path"].items())]
assert len(fields) == 9 and all(x is not None for x in fields), len(fields)
assert not any(np.array_equal(a, b) for a, b in zip(fields, fields[1:])), "the same shapes"
cores = [float(x.min()) for x in fields]  # the tube's core: from 0.02 deep to 0.05
assert abs(cores[0] + 0.02) < 0.008 and abs(cores[-1] + 0.05) < 0.008, cores
assert bpy.ops.hydrobake.bake(effect="fluid", object_name="Domain") == {"FINISHED"}
print("FLUID CURVE DEFORMING OK")

# A metaball family: the member alone in Holders (its own evaluated mesh is empty, its box a
# point) is the pair's surface, held by the basis outside the collection.
bpy.data.objects.remove(ring)
bpy.ops.object.metaball_add(type="BALL", radius=0.15, location=(0.2, 0.5, 0.1))
basis = bpy.context.active_object
bpy.ops.object.metaball_add(type="BALL", radius=0.15, location=(0.5, 0.5, 0.1))
member = bpy.context.active_object
basis.name, member.name = "Pair", "Pair.001"
for coll in list(member.users_collection):
    coll.objects.unlink(member)
holders.objects.link(member)
scene.frame_set(1)


def field_at(ob, p):
    """The obstacle's field (in its own axes, unturned here) at world point p: nearest point."""
    _, c, e, _, field = ob
    zs, ys, xs = (np.linspace(-h, h, n) for h, n in zip(e[::-1], field.shape))
    q = np.subtract(p, c)
    return field[np.argmin(np.abs(zs - q[2])), np.argmin(np.abs(ys - q[1])),
                 np.argmin(np.abs(xs - q[0]))]


for members in ((member,), (member, basis)):
    for o in members:
        if holders not in o.users_collection:
            holders.objects.link(o)
    obs = in_blender.fluid_inputs(domain)["obstacles"]
    assert len(obs) == 1 and obs[0][0] == "mesh", [ob[0] for ob in obs]
    assert np.allclose(obs[0][1], (0.35, 0.5, 0.1), atol=0.01), obs[0][1]
    inside = [field_at(obs[0], (x, 0.5, 0.1)) for x in (0.2, 0.5)]
    between = field_at(obs[0], (0.35, 0.5, 0.1))
    assert max(inside) < -0.04 and between > 0.03, (inside, between)
# (the same surface for rays: a caustics Disturber that is a member)
from hydrobake.blender.bridge import meshes  # noqa: E402
tops = meshes.sample_heights(member, (0.0, 0.475), 0.05, (1, 16))[0]
assert np.isfinite(tops[[4, 9]]).all() and np.isnan(tops[[0, 6, 7, 13]]).all(), tops
print("FLUID CURVE FAMILY OK")

# The member moves, the basis stands: the family's surface changes shape every frame.
member.location.x = 0.45
member.keyframe_insert("location", frame=1)
member.location.x = 0.65
member.keyframe_insert("location", frame=9)
holders.objects.unlink(basis)
scene.frame_set(1)
inp = in_blender.fluid_inputs(domain)
fields = [inp["obstacles"][0]] + [o[0] for _, o in sorted(inp["obstacle_path"].items())]
assert len(fields) == 9 and all(ob[4] is not None for ob in fields), len(fields)
at = [field_at(ob, (x, 0.5, 0.1)) for ob in (fields[0], fields[-1]) for x in (0.45, 0.65)]
assert at[0] < -0.04 < 0.04 < at[1] and at[3] < -0.04 < 0.04 < at[2], at
print("FLUID CURVE FAMILY MOVING OK")
