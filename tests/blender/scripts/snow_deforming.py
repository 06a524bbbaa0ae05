"""Snow on a mesh that deforms (shape keys, an armature, a cloth) is simulated on its shape of
every frame: a cube squashed by an animated shape key, and also moving, is given to the core
as its world vertices on each frame they change, exactly the evaluated mesh's, and so is one
whose Bevel width is keyed; a still mesh under a Subdivision is given once; a shape whose
faces change from frame to frame (a Remesh of the squashing cube, in BOX mode) is taken at the
first frame with a warning naming the object and the frame, and BOX mode on a deforming
shape warns that its boxes are the first frame's. The operator's bake records the
shapes frame by frame."""
import json
import os

import bpy
import numpy as np

import in_blender

in_blender.enable()
from hydrobake.blender import jobs  # noqa: E402
from hydrobake.core.arrays import digest  # noqa: E402

tmp = in_blender.args()[0]
bpy.ops.wm.save_as_mainfile(filepath=os.path.join(tmp, "deforming.blend"))
scene = bpy.context.scene
cube = bpy.data.objects["Cube"]
s = in_blender.snow(cube, (1, 6), 20, 32)
s.auto_volume = False


def job_inputs():
    """The inputs a bake of the cube gives the core, and the warnings it gives."""
    job = jobs.Job(bpy.context, cube, "snow")
    try:
        e = job.runner.effect
        placed = {f: e.frame_inputs(f)["mesh position"] for f in range(1, 7)}
        return e.inputs, placed, job.warnings
    finally:
        job.runner.effect.close()
        del cube.hydrobake_snow[jobs.BAKING]


def world_vertices(frame):
    """The cube's evaluated vertices in the world at ``frame``, as the test reads them."""
    scene.frame_set(frame)
    ev = cube.evaluated_get(bpy.context.evaluated_depsgraph_get())
    mesh = ev.to_mesh()
    co = np.empty(len(mesh.vertices) * 3, np.float32)
    mesh.vertices.foreach_get("co", co)
    ev.to_mesh_clear()
    m = np.array(cube.matrix_world, np.float64)
    return (co.reshape(-1, 3) @ m[:3, :3].T + m[:3, 3]).astype(np.float32)


# A still cube under a Subdivision: given once, in the world; the scene is not stepped.
cube.modifiers.new("Smooth", "SUBSURF").levels = 1
inputs, placed, warned = job_inputs()
assert "frame_positions" not in inputs and "transforms" not in inputs, sorted(inputs)
assert len(set(placed.values())) == 1 and warned == []

# A Bevel whose width is keyed: the shape changes though no modifier takes the frame.
shell = cube.modifiers.new("Rounded", "BEVEL")
for frame, width in ((1, 0.02), (6, 0.2)):
    shell.width = width
    shell.keyframe_insert("width", frame=frame)
inputs, placed, warned = job_inputs()
assert sorted(inputs.get("frame_positions", ())) == [2, 3, 4, 5, 6], sorted(inputs)
assert len(set(placed.values())) == 6 and warned == []
cube.animation_data_clear()
cube.modifiers.remove(shell)

# Squashed to a fifth of its height from frame 1 to 5 by a shape key, and moving from 1 to 6.
cube.shape_key_add(name="Basis")
key = cube.shape_key_add(name="Squash")
for v in key.data:
    v.co.z *= 0.2
for frame, value in ((1, 0.0), (5, 1.0)):
    key.value = value
    key.keyframe_insert("value", frame=frame)
for frame, x in ((1, 0.0), (3, 0.0), (6, 0.5)):
    cube.location.x = x
    cube.keyframe_insert("location", frame=frame)
scene.frame_set(4)  # (a bake reads the first frame whatever frame the scene is on)
inputs, placed, warned = job_inputs()
assert scene.frame_current == 4
assert "transforms" not in inputs and sorted(inputs["frame_positions"]) == [2, 3, 4, 5, 6]
assert warned == []
for f in range(1, 7):  # exactly the evaluated mesh, where it is
    assert placed[f] == digest(world_vertices(f)), f"frame {f}: not the evaluated mesh"
assert len(set(placed.values())) == 6
squashed = placed
top = world_vertices(5)[:, 2].max()
assert top < 0.2, top  # squashed (the Subdivision's top is a little under the cage's 0.2)

# In BOX mode the snow is shown by the first frame's boxes: the squash is followed, with a
# warning that the boxes do not follow it.
s.snow.contact_mode = "BOX"
inputs, placed, warned = job_inputs()
assert sorted(inputs["frame_positions"]) == [2, 3, 4, 5, 6], sorted(inputs)
assert warned == ["Cube: Contact Mode BOX shows the snow by the boxes of the bake's first "
                  "frame (1), but the shape deforms after it, so the snow drifts from where it "
                  "landed: use TRIANGLES (with a UV map) for a deforming shape"], warned
s.snow.contact_mode = "TRIANGLES"

# A Remesh over the squash: the faces change from frame to frame.
remesh = cube.modifiers.new("Blocks", "REMESH")
remesh.mode, remesh.voxel_size = "VOXEL", 0.15
s.snow.contact_mode = "BOX"  # (a Remesh drops the UV map)
inputs, placed, warned = job_inputs()
assert "frame_positions" not in inputs and "transforms" in inputs, sorted(inputs)
assert len(warned) == 1 and warned[0].startswith("Cube: its mesh has ") and \
    "snow cannot follow faces that change, so its shape is taken at frame 1" in warned[0], warned
cube.modifiers.remove(remesh)
s.snow.contact_mode = "TRIANGLES"

# The operator's bake records the squash and the motion frame by frame.
assert bpy.ops.hydrobake.bake(effect="snow", object_name="Cube") == {"FINISHED"}
with open(os.path.join(s.bake_folder, "manifest.json")) as f:
    m = json.load(f)
assert [m["frame_inputs"][str(f)]["mesh position"] for f in range(1, 7)] == \
    [squashed[f] for f in range(1, 7)]
print("SNOW DEFORMING OK")
