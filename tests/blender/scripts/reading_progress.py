"""A bake that steps the scene through its frames on the main thread (a deforming mesh's
snow) says how far it has got, in background mode as lines like the bake's own; the reporter
is let go when the bake is made and when making it fails."""
import contextlib
import io
import os

import bpy

import in_blender

in_blender.enable()
from hydrobake.blender import jobs, reading_progress  # noqa: E402
from hydrobake.blender.bridge import animation  # noqa: E402

tmp = in_blender.args()[0]
bpy.ops.wm.save_as_mainfile(filepath=os.path.join(tmp, "reading.blend"))
cube = bpy.data.objects["Cube"]
cube.modifiers.new("Wave", "WAVE").height = 0.05  # a shape that changes every frame
s = in_blender.snow(cube, (3, 8), 20, 32)
reading_progress.ReadingProgress.EVERY = 0.0  # a line for every frame

out = io.StringIO()
with contextlib.redirect_stdout(out):
    job = jobs.Job(bpy.context, cube, "snow")
job.runner.effect.close()
del s[jobs.BAKING]
lines = [ln for ln in out.getvalue().splitlines() if "reading the scene" in ln]
assert [ln.split(": frame ")[1].split(" elapsed")[0] for ln in lines] == [
    f"{f} ({f - 2}/6)" for f in range(3, 9)], lines
assert all(ln.startswith("hydrobake: Cube/snow reading the scene: frame ") for ln in lines)
assert animation._reporter is None

# Refused after the frames are read (the flakes fill the volume the shapes swept): the
# reporter goes all the same.
s.flake_density = 1e6
out = io.StringIO()
try:
    with contextlib.redirect_stdout(out):
        jobs.Job(bpy.context, cube, "snow")
    raise AssertionError("a million flakes per m³ were baked")
except ValueError as exc:
    assert "Flake Density" in str(exc), exc
assert "(6/6)" in out.getvalue(), out.getvalue()
assert animation._reporter is None
print("READING PROGRESS OK", len(lines))
