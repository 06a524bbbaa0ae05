"""BOX mode's projection takes each face's tile from its world normal: a steep roof made by
an object scale (Y 0.25) takes the same tile as the same roof with its scale applied (its
normals transform by the inverse transpose, not by the matrix itself)."""
import os

import bpy
import numpy as np

import in_blender

in_blender.enable()

tmp = in_blender.args()[0]
bpy.data.objects.remove(bpy.data.objects["Cube"])
bpy.ops.wm.save_as_mainfile(filepath=os.path.join(tmp, "box_scale.blend"))


def wedge(name, x, apply):
    """A wedge whose sloped face (polygon 1) rises towards +Y, squashed to 72 degrees."""
    me = bpy.data.meshes.new(name)
    me.from_pydata([(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0), (-1, 1, 1.5), (1, 1, 1.5)],
                   [], [(3, 2, 1, 0), (0, 1, 5, 4), (2, 3, 4, 5), (0, 4, 3), (1, 2, 5)])
    me.uv_layers.new(name="UVMap")
    o = bpy.data.objects.new(name, me)
    bpy.context.scene.collection.objects.link(o)
    o.location.x, o.scale.y = x, 0.25
    if apply:
        bpy.ops.object.select_all(action="DESELECT")
        o.select_set(True)
        bpy.context.view_layer.objects.active = o
        bpy.ops.object.transform_apply(scale=True)
    me.materials.append(bpy.data.materials.new(name))
    s = in_blender.snow(o, (1, 2), 20, 96)
    s.snow.contact_mode = "BOX"
    assert bpy.ops.hydrobake.bake(effect="snow", object_name=name) == {"FINISHED"}
    ev = o.evaluated_get(bpy.context.evaluated_depsgraph_get()).to_mesh()
    uv = np.empty(len(ev.loops) * 3, np.float32)
    ev.attributes["HBK_SnowBox"].data.foreach_get("vector", uv)
    uv = uv.reshape(-1, 3)[:, :2]
    return [uv[list(p.loop_indices)] for p in ev.polygons]


scaled, applied = wedge("Scaled", 0, False), wedge("Applied", 5, True)
for k, (a, b) in enumerate(zip(scaled, applied)):
    assert np.allclose(a, b, atol=1e-5), (k, a, b)
# The slope (world normal mostly -Y) is on the -Y tile: the middle column, bottom row.
slope = applied[1]
assert np.all((slope[:, 0] >= 32 / 96 - 1e-6) & (slope[:, 0] <= 64 / 96 + 1e-6)), slope
assert np.all(slope[:, 1] <= 0.5 + 1e-6), slope
print("SNOW BOX SCALE OK")
