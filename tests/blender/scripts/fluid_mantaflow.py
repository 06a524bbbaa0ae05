"""Fluid texturing driven by a real Mantaflow liquid: Blender bakes a falling ball of liquid,
the addon reads its OpenVDB velocity cache and its liquid mesh. The velocity arrives in m/s
(free fall: g t; with a time scale, what a frame moves), the textures move with the liquid, and
the textured surface is where Mantaflow's liquid is."""
import json
import os

import bpy
import numpy as np

import in_blender

in_blender.enable()
from hydrobake.core import vdb  # noqa: E402
from hydrobake.core.bake.cache import frame_path  # noqa: E402

tmp = in_blender.args()[0]
# An optional time scale: a slowed simulation moves the textures by what a frame moves.
time_scale = float(in_blender.args()[1]) if len(in_blender.args()) > 1 else 1.0
bpy.ops.wm.save_as_mainfile(filepath=os.path.join(tmp, "liquid.blend"))
scene = bpy.context.scene
scene.frame_start, scene.frame_end = 1, 5
scene.render.fps = 24
dom, d, _flow = in_blender.liquid((0, 0, 1), 24, os.path.join(tmp, "manta"), 0.4, (0, 0, 1.3))
d.time_scale = time_scale
in_blender.bake_liquid(dom)

s = dom.hydrobake_fluid
s.enabled = True
s.fluid.source = "VELOCITY_GRID"
s.fluid.resolution = (16, 16, 16)
s.fluid.textures = 2
s.use_scene_range, s.frame_start, s.frame_end = False, 1, 5
assert bpy.ops.hydrobake.bake(effect="fluid", object_name="Tank") == {"FINISHED"}
m = json.load(open(os.path.join(s.bake_folder, "manifest.json")))
assert m["params"]["fluid"]["box_min"] == [-1.0, -1.0, 0.0], m["params"]["fluid"]["box_min"]

# Free fall: the fastest downward velocity after f frames is g f / 24 (to a cell's error).
# Slowed by the time scale, the ball has fallen for f / 24 * time_scale simulated seconds,
# and a frame moves it by that speed times the time scale.
for f in (2, 4):
    g = vdb.read_grid(frame_path(s.bake_folder, "fluid", f, "vdb"), "velocity")
    vz, want = g[..., 2], -9.81 * f / 24 * time_scale * time_scale
    assert abs(vz.min() - want) < 0.1 * abs(want), (f, vz.min(), want)
if time_scale != 1.0:
    print("FLUID MANTAFLOW TIME SCALE OK", round(float(g[..., 2].min()), 4))
    raise SystemExit(0)
# The textures move with the liquid: uvw changed where it flows, not at rest far from it.
# (The grids hold values only where there is liquid: read them over one common box.)
uvw1 = vdb.read_grid(frame_path(s.bake_folder, "fluid", 1, "vdb"), "uvw")
uvw5 = vdb.read_grid(frame_path(s.bake_folder, "fluid", 5, "vdb"), "uvw")
box = np.maximum(uvw1.shape, uvw5.shape)
uvw1, uvw5 = (np.pad(u, [(0, b - n) for b, n in zip(box, u.shape)]) for u in (uvw1, uvw5))
moved = np.abs(uvw5 - uvw1).max(axis=-1) > 1e-3
assert 0 < moved.mean() < 1, moved.mean()
# The surface is Mantaflow's liquid: its lowest point matches the liquid mesh's.
scene.frame_set(5)
ev = dom.evaluated_get(bpy.context.evaluated_depsgraph_get())
liquid_z = min((dom.matrix_world @ v.co).z for v in ev.to_mesh().vertices)
ev.to_mesh_clear()
surf = np.load(frame_path(s.bake_folder, "surface", 5, "npz"))
assert len(surf["triangles"]) > 100
ours = surf["positions"][:, 2].min()
assert abs(ours - liquid_z) < 2.5 * 2.0 / 16, (ours, liquid_z)  # within the grid's resolution
assert bpy.ops.hydrobake.free_bake(effect="fluid", object_name="Tank") == {"FINISHED"}
# With Mesh off there is no surface: baked, but warned of (the textured object stays empty).
from hydrobake.blender import jobs  # noqa: E402
job = jobs.Job(bpy.context, dom, "fluid")
job.runner.effect.close()
assert not [w for w in job.warnings if w.startswith("Liquid Domain")], job.warnings
d.use_mesh = False
job = jobs.Job(bpy.context, dom, "fluid")
job.runner.effect.close()
domain_said = [w for w in job.warnings if w.startswith("Liquid Domain")]
assert len(domain_said) == 1 and domain_said[0].startswith(
    "Liquid Domain: Tank has Mesh off, so there is no liquid surface"), job.warnings
d.use_mesh = True
# A domain disabled in viewports is not evaluated: its liquid mesh would be read as its box.
dom.hide_viewport = True
said = [k.get("text") for n, a, k in in_blender.panel_calls(dom, "fluid") if n == "label"]
assert "Not evaluated in this view layer: Liquid Domain: Tank" in said, said
try:
    jobs.Job(bpy.context, dom, "fluid")
    raise AssertionError("read a domain Blender does not evaluate")
except ValueError as exc:
    assert str(exc).startswith("Liquid Domain: 'Tank' is not evaluated in view layer"), exc
dom.hide_viewport = False

# Errors name the setting.
plain = in_blender.new_plane("Plain")
p = plain.hydrobake_fluid
p.enabled = True
p.fluid.source = "VELOCITY_GRID"
try:
    bpy.ops.hydrobake.bake(effect="fluid", object_name="Plain")
    raise AssertionError("baked without a liquid domain")
except RuntimeError as exc:
    assert "Liquid Domain: Plain has no Fluid modifier" in str(exc), exc
print("FLUID MANTAFLOW OK", round(float(ours), 3), round(float(liquid_z), 3))
