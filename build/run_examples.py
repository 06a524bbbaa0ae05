"""Inside Blender (build/main.sh): bake every enabled effect of every scene of the open .blend
through the addon's batch path, then render one still per scene to <out>/<scene>.png.

Arguments after '--': OUT_DIR [--samples N] [--resolution PERCENT] [--scenes A,B]."""
import argparse
import os
import sys
import time

import addon_utils
import bpy

argv = sys.argv[sys.argv.index("--") + 1:]
ap = argparse.ArgumentParser()
ap.add_argument("out")
ap.add_argument("--samples", type=int, default=None)
ap.add_argument("--resolution", type=int, default=None)
ap.add_argument("--scenes", default="", help="comma-separated scene names (default: all)")
args = ap.parse_args(argv)

addon_utils.enable("hydrobake", default_set=False)
from hydrobake.blender import effects, jobs  # noqa: E402

known = effects.load_all()
cache = os.path.join(os.path.abspath(args.out), "cache")
failed = False
only = [n for n in args.scenes.split(",") if n]
for scene in bpy.data.scenes:
    if only and scene.name not in only:
        continue
    for obj in scene.objects:
        for name in known:
            settings = getattr(obj, f"hydrobake_{name}", None)
            if settings is None or not settings.enabled:
                continue
            t0 = time.monotonic()
            job = jobs.Job(bpy.context, obj, name, folder_override=cache, scene=scene)
            jobs.ACTIVE[job.key] = job
            try:
                job.runner.run()
            except Exception as exc:
                print(f"run_examples: {scene.name}/{obj.name}/{name} failed: {exc}",
                      file=sys.stderr)
                failed = True
            finally:
                job.finalize(bpy.context)
            s = job.runner.state
            print(f"run_examples: baked {scene.name}/{obj.name}/{name}: {s.done} frames in "
                  f"{time.monotonic() - t0:.1f}s", flush=True)
    render = scene.render
    scene.cycles.use_denoising = False  # Debian's Cycles has no denoiser
    if args.samples:
        scene.cycles.samples = args.samples
    if args.resolution:
        render.resolution_percentage = args.resolution
    still = int(scene.get("hydrobake_still_frame", scene.frame_current))
    name = bpy.path.clean_name(scene.name)
    final = os.path.join(os.path.abspath(args.out), f"{name}.png")
    # Rendered under a temporary name and renamed when written: a killed run never leaves a
    # half-written still in place of the last good one.
    render.filepath = os.path.join(os.path.dirname(final), f".{name}.tmp-{os.getpid()}.png")
    render.image_settings.file_format = "PNG"
    t0 = time.monotonic()
    # Render with this scene as the context scene: otherwise the render re-evaluates at the
    # context scene's frame and frame handlers (baked meshes, flakes) load the wrong frame.
    try:
        with bpy.context.temp_override(scene=scene):
            scene.frame_set(still)
            bpy.ops.render.render(write_still=True, scene=scene.name)
        os.replace(render.filepath, final)
    finally:
        if os.path.exists(render.filepath):
            os.remove(render.filepath)
    render.filepath = final
    print(f"run_examples: rendered {final} in {time.monotonic() - t0:.1f}s", flush=True)
bpy.ops.wm.save_mainfile()
sys.exit(1 if failed else 0)
