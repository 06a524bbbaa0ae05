"""Benchmark (not a test): a full snow bake of a 126k-face subdivided Suzanne with Hydrobake,
next to Blender's bundled Real Snow addon on the same mesh, in the same run.

    BLENDER_USER_SCRIPTS=build/_work/blender_home/scripts blender -b --factory-startup \
        --python-exit-code 1 --python build/bench_snow_blender.py -- [FRAMES] [FLAKES]

(the addon installed there by build/main.sh; see README, Benchmarks)."""
import os
import sys
import tempfile
import time

import addon_utils
import bpy
import numpy as np
from mathutils import Vector

argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []


def int_arg(i, name, default, lo, hi):
    """argv[i] in [lo, hi]: a bad one stops the run before anything is timed."""
    if len(argv) <= i:
        return default
    try:
        value = int(argv[i])
    except ValueError:
        value = None
    if value is None or not lo <= value <= hi:
        print(f"bench_snow_blender: {name} must be an integer in [{lo}, {hi}], got {argv[i]!r}",
              file=sys.stderr)
        sys.exit(2)
    return value


if len(argv) > 2:
    print(f"bench_snow_blender: at most 2 arguments (FRAMES FLAKES), got {len(argv)}",
          file=sys.stderr)
    sys.exit(2)
bpy.ops.wm.read_factory_settings(use_empty=True)
for name in ("hydrobake", "real_snow"):
    if addon_utils.enable(name, default_set=False) is None:
        print(f"bench_snow_blender: the addon {name} is not installed for this Blender "
              "(run build/main.sh, then set BLENDER_USER_SCRIPTS as the docstring shows)",
              file=sys.stderr)
        sys.exit(2)
flake_rna = (bpy.types.Object.bl_rna.properties["hydrobake_snow"].fixed_type
             .properties["snow"].fixed_type.properties["flake_count"])
frames = int_arg(0, "FRAMES", 48, 1, 1048574)  # Blender's last frame
flakes = int_arg(1, "FLAKES", 1000000, flake_rna.hard_min, flake_rna.hard_max)
tmp = tempfile.mkdtemp(prefix="hbk_bench_")
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
# FLAKES flakes exactly: the volume Auto Volume would fit, set by hand (Auto Volume would
# set the count from its Flake Density).
from hydrobake.blender.effects.snow import auto_volume  # noqa: E402
corners = np.array([suz.matrix_world @ Vector(c) for c in suz.bound_box])
s.auto_volume = False
s.snow.volume_min, s.snow.volume_max = auto_volume(
    corners.min(axis=0), corners.max(axis=0), s.snow.wind, s.snow.fall_speed)
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
