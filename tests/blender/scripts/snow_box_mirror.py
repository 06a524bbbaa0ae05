"""BOX mode with a Mirror modifier: the boxes are measured on the evaluated mesh, as the
simulation saw it, and the mirrored faces take their own place in the tile. A roof shelters
the x < 0 half of a block mirrored from its x > 0 half: the top shows snow at x > 0 only."""
import os

import bpy
import numpy as np

import in_blender

in_blender.enable()
from hydrobake.core import exr  # noqa: E402
from hydrobake.core.bake.cache import frame_path  # noqa: E402

tmp = in_blender.args()[0]
bpy.data.objects.remove(bpy.data.objects["Cube"])
bpy.ops.wm.save_as_mainfile(filepath=os.path.join(tmp, "box_mirror.blend"))
bpy.ops.mesh.primitive_cube_add(size=1, location=(0.5, 0, 0.5))
block = bpy.context.object
block.name = "Block"
bpy.ops.object.transform_apply(location=True)  # the right half, x 0..1 ...
block.modifiers.new("Mirror", "MIRROR")  # ... mirrored to x -1..1
block.data.materials.append(bpy.data.materials.new("M"))
bpy.ops.mesh.primitive_plane_add(size=1, location=(-0.75, 0, 1.002))
roof = bpy.context.object
roof.scale = (1.5, 2, 1)
shelter = bpy.data.collections.new("Shelter")
shelter.objects.link(roof)
s = in_blender.snow(block, (1, 4), 7500, 96)
s.snow.wind = (0.0, 0.0, 0.0)
s.snow.flutter_amplitude = 0.0
s.snow.fall_speed = 3.0
s.colliders = shelter
s.snow.contact_mode = "BOX"
assert bpy.ops.hydrobake.bake(effect="snow", object_name="Block") == {"FINISHED"}
cov = exr.read(frame_path(s.bake_folder, "coverage", 4, "exr"))["A"]
H, W = cov.shape
ev = block.evaluated_get(bpy.context.evaluated_depsgraph_get()).to_mesh()
uv = np.empty(len(ev.loops) * 3, np.float32)
ev.attributes["HBK_SnowBox"].data.foreach_get("vector", uv)
uv = uv.reshape(-1, 3)[:, :2]


def seen(x):
    """The coverage the material shows on the top at world (x, 0)."""
    for p in ev.polygons:
        pts = np.array([(*ev.vertices[ev.loops[i].vertex_index].co[:2], 1)
                        for i in p.loop_indices])
        if p.normal.z > 0.9 and pts[:, 0].min() <= x <= pts[:, 0].max():
            a = np.linalg.lstsq(pts, uv[list(p.loop_indices)], rcond=None)[0]
            u, v = np.array([x, 0, 1]) @ a
            return float(cov[min(int(v * H), H - 1), min(int(u * W), W - 1)])


got = {x: seen(x) for x in (-0.9, -0.6, -0.3, 0.3, 0.6, 0.9)}
print("top coverage by world x (roof over x < 0):", got)
assert all(got[x] == 0.0 for x in (-0.9, -0.6, -0.3)), got
assert all(got[x] > 0.0 for x in (0.3, 0.6, 0.9)), got
print("SNOW BOX MIRROR OK")
