"""A frame of snow lasts 1/fps of scene time at any frame rate: flakes without wind or flutter
fall at Fall Speed in scene time at 60 fps (one substep, shorter than Time Step) and at
12 fps (two substeps of 1/24 s); the bake records the substep it took, is deterministic, and
resumes."""
import json
import os

import bpy
import numpy as np

import in_blender

in_blender.enable()

from hydrobake.core.bake.cache import frame_path  # noqa: E402

tmp = in_blender.args()[0]
bpy.ops.wm.save_as_mainfile(filepath=os.path.join(tmp, "fps.blend"))
scene = bpy.context.scene
cube = bpy.data.objects["Cube"]
s = in_blender.snow(cube, (1, 3), 20, 64)
s.snow.wind = (0.0, 0.0, 0.0)
s.snow.flutter_amplitude = 0.0
s.snow.fall_speed = 1.0
s.write_flakes = True


def manifest():
    with open(os.path.join(s.bake_folder, "manifest.json")) as f:
        return json.load(f)


for fps, substeps in ((60, 1), (12, 2)):
    scene.render.fps = fps
    assert bpy.ops.hydrobake.bake(effect="snow", object_name="Cube") == {"FINISHED"}
    z = [np.load(frame_path(s.bake_folder, "flakes", f, "npz"))["positions"][:, 2]
         for f in (2, 3)]
    d = z[0] - z[1]
    d = d[(d > 0) & (d < 0.5)]  # falling, not respawned at the top
    speed = float(np.median(d)) * fps
    print(f"{fps} fps: flakes fall at {speed:.3f} m/s of scene time")
    assert abs(speed - 1.0) < 0.02, (fps, speed)
    m = manifest()
    step = m["params"]["snow"]["time_step"]
    assert abs(step * substeps - 1.0 / fps) < 1e-6, (fps, step)
    if "inputs" in m:
        assert m["inputs"]["substeps"] == substeps, m["inputs"]
    frames = m["frames"]
    assert bpy.ops.hydrobake.bake(effect="snow", object_name="Cube") == {"FINISHED"}
    assert manifest()["frames"] == frames  # the same bytes again
    assert bpy.ops.hydrobake.bake(effect="snow", object_name="Cube", resume=True) == \
        {"FINISHED"}  # the recorded parameters still validate and match
    assert manifest()["frames"] == frames
    assert bpy.ops.hydrobake.free_bake(effect="snow", object_name="Cube") == {"FINISHED"}
print("SNOW FPS OK")
