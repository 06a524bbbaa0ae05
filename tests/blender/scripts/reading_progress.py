"""A bake that steps the scene through its frames on the main thread (a deforming mesh's
snow) says how far it has got, in background mode as lines like the bake's own, and sets the
scene back on its frame when the bake is made and when making it fails. Made a step at a
time (Job.stepwise, as a UI bake is), it reads one frame a step, can be stopped between
frames (nothing marked, the scene back on its frame), and run to its end it reads what a Job
made at once does."""
import contextlib
import io
import os

import bpy

import in_blender

in_blender.enable()
from hydrobake.blender import jobs, reading_progress  # noqa: E402

tmp = in_blender.args()[0]
bpy.ops.wm.save_as_mainfile(filepath=os.path.join(tmp, "reading.blend"))
cube = bpy.data.objects["Cube"]
cube.modifiers.new("Wave", "WAVE").height = 0.05  # a shape that changes every frame
s = in_blender.snow(cube, (3, 8), 20, 32)
reading_progress.ReadingProgress.EVERY = 0.0  # a line for every frame
scene = bpy.context.scene
scene.frame_set(5)

out = io.StringIO()
with contextlib.redirect_stdout(out):
    job = jobs.Job(bpy.context, cube, "snow")
at_once = job.runner.effect
del s[jobs.BAKING]
lines = [ln for ln in out.getvalue().splitlines() if "reading the scene" in ln]
assert [ln.split(": frame ")[1].split(" elapsed")[0] for ln in lines] == [
    f"{f} ({f - 2}/6)" for f in range(3, 9)], lines
assert all(ln.startswith("hydrobake: Cube/snow reading the scene: frame ") for ln in lines)
assert scene.frame_current == 5

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
assert scene.frame_current == 5
s.flake_density = 20

# A step at a time: stopped after two frames, nothing is left of it.
reading = jobs.Job.stepwise(bpy.context, cube, "snow")
assert reading.step() == (3, 1, 6) and scene.frame_current == 3
assert reading.step() == (4, 2, 6) and scene.frame_current == 4
reading.close()
assert scene.frame_current == 5 and jobs.BAKING not in s and not jobs.ACTIVE
# Run to its end: the same inputs as the Job made at once.
reading = jobs.Job.stepwise(bpy.context, cube, "snow")
steps = []
while reading.step() is not None:
    steps.append(reading.last)
reading.close()
assert [f for f, _, _ in steps] == list(range(3, 9)) and scene.frame_current == 5, steps
stepped = reading.job.runner.effect
assert stepped.scene_inputs() == at_once.scene_inputs()
assert all(stepped.frame_inputs(f) == at_once.frame_inputs(f) for f in range(3, 9))
stepped.close()
at_once.close()
del s[jobs.BAKING]
print("READING PROGRESS OK", len(lines))
