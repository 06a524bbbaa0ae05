"""Benchmark (not a test): a full snow bake of a 126k-face subdivided Suzanne with Hydrobake,
next to Blender's bundled Real Snow addon on the same mesh, in the same run.

    blender -b --factory-startup --python build/bench_snow_blender.py -- [FRAMES] [FLAKES]

(with the addon installed, as build/main.sh does; see README, Benchmarks)."""
import os
import sys
import tempfile
import time

import addon_utils
import bpy

argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
frames = int(argv[0]) if argv else 48
flakes = int(argv[1]) if len(argv) > 1 else 1000000

tmp = tempfile.mkdtemp(prefix="hbk_bench_")
bpy.ops.wm.read_factory_settings(use_empty=True)
addon_utils.enable("hydrobake", default_set=False)
addon_utils.enable("real_snow", default_set=False)
from hydrobake.blender import jobs  # noqa: E402
bpy.ops.wm.save_as_mainfile(filepath=os.path.join(tmp, "suzanne.blend"))
bpy.ops.mesh.primitive_monkey_add(size=2.0, location=(0, 0, 1))
suz = bpy.context.object
mod = suz.modifiers.new("Subdivision", "SUBSURF")
mod.levels = 4
bpy.ops.object.modifier_apply(modifier=mod.name)
faces = len(suz.data.polygons)
scene = bpy.context.scene
scene.frame_start, scene.frame_end = 1, frames

# Hydrobake: a full bake of `frames` frames of falling snow.
s = suz.hydrobake_snow
s.enabled = True
s.snow.flake_count = flakes
s.snow.texture_width = s.snow.texture_height = 2048
t0 = time.monotonic()
job = jobs.Job(bpy.context, suz, "snow", threads=0)
t_prep = time.monotonic() - t0
job.runner.run()
t_hbk = time.monotonic() - t0
stats = job.runner.effect.snow.stats()
job.finalize(bpy.context)

# Real Snow on the same mesh (its defaults: 100 % coverage, 0.3 height).
bpy.ops.object.select_all(action="DESELECT")
suz.select_set(True)
bpy.context.view_layer.objects.active = suz
t0 = time.monotonic()
bpy.ops.snow.create()
# Real Snow's metaballs are meshed when the scene is evaluated: count that too.
dg = bpy.context.evaluated_depsgraph_get()
dg.update()
snow_objs = [o for o in bpy.data.objects if o.name.startswith("Snow")]
made = sum(len(o.evaluated_get(dg).to_mesh().polygons) for o in snow_objs)
t_real = time.monotonic() - t0

print(f"| mesh | tool | what it makes | time (s) |")
print(f"|---|---|---|---:|")
print(f"| Suzanne, {faces} faces | Hydrobake snow ({frames} frames, {flakes} flakes, "
      f"{stats['flake_steps'] / max(t_hbk - t_prep, 1e-9) / 1e6:.1f} M flake-steps/s) | "
      f"2048² coverage + depth per frame, {stats['stuck']} flakes stuck | {t_hbk:.2f} "
      f"(scene read {t_prep:.2f}) |")
print(f"| Suzanne, {faces} faces | Real Snow (bundled addon, defaults) | one metaball snow "
      f"mesh, {made} faces, evaluated | {t_real:.2f} |")
