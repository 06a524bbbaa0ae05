"""Curves, texts and metaballs as the fluid's obstacles: each is the mesh Blender evaluates it
to, made a distance field as a mesh is. A bevelled circle is a ring the dam break's water
falls through (its box, what the addon took before, held it all); a curve without bevel is
its box; a text with depth and a metaball are their shapes; a keyed bevel changes the
curve's shape, so it gets a field at every frame."""
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
