"""Resume checks the scene against the bake it continues. A snow bake of frames 1-3 on a cube
that moves from frame 3 on: the move after frame 3 edited, then Resume to frame 5, gives the
bake of the scene as it is now. The motion of a kept frame edited, or the mesh subdivided,
Resume is refused by name, and the bake, its files and its record stay as they were."""
import json
import os

import bmesh
import bpy

import in_blender

in_blender.enable()

tmp = in_blender.args()[0]
bpy.ops.wm.save_as_mainfile(filepath=os.path.join(tmp, "resume.blend"))
cube = bpy.data.objects["Cube"]
s = in_blender.snow(cube, (1, 3), 20, 32)
s.auto_volume = False  # (the volume would follow the motion: a refusal of its own)


def key(frame, x):
    cube.location = (x, 0.0, 0.0)
    cube.keyframe_insert("location", frame=frame)


def bake(resume=False):
    return bpy.ops.hydrobake.bake(effect="snow", object_name="Cube", resume=resume)


def made():
    """The frames' checksums, by frame and stream (not the file names' tag)."""
    with open(os.path.join(s.bake_folder, "manifest.json")) as f:
        m = json.load(f)
    return {f: sorted(files.values()) for f, files in m["frames"].items()}


def folder_now():
    return {n: os.path.getmtime(os.path.join(s.bake_folder, n))
            for n in sorted(os.listdir(s.bake_folder))}


def refused(want):
    before, folder = folder_now(), s.bake_folder
    try:
        bake(resume=True)
        raise AssertionError(f"resumed though {want}")
    except RuntimeError as exc:
        assert "cannot resume the bake in " in str(exc) and want in str(exc), exc
    assert s.is_baked and s.bake_folder == folder and folder_now() == before


key(1, 0.0)
key(3, 0.0)
key(5, 0.4)
assert bake() == {"FINISHED"}
key(5, 0.6)  # after the kept frames: baked from the scene as it is now
s.frame_end = 5
assert bake(resume=True) == {"FINISHED"}
resumed = made()
assert sorted(resumed, key=int) == ["1", "2", "3", "4", "5"]
assert bpy.ops.hydrobake.free_bake(effect="snow", object_name="Cube") == {"FINISHED"}
assert bake() == {"FINISHED"}
assert made() == resumed, "the resumed bake differs from a bake of the same scene"

key(3, 0.2)  # frame 2 now moves: the bake does not hold this scene's frames
refused("mesh position at frame 2: changed since the bake")
key(3, 0.0)
bm = bmesh.new()
bm.from_mesh(cube.data)
bmesh.ops.subdivide_edges(bm, edges=bm.edges[:], cuts=1, use_grid_fill=True)
bm.to_mesh(cube.data)
bm.free()
refused("mesh: changed since the bake")
print("RESUME CHANGED SCENE OK")
