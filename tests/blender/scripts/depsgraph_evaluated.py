"""bridge.depsgraph.evaluated: the graph context.evaluated_depsgraph_get() gives, evaluated
after an edit, in the window's scene and in another scene under a context override (which
is why it exists: no context lookup while Python's lock is let go)."""
import bpy

import in_blender

in_blender.enable()
from hydrobake.blender.bridge.depsgraph import evaluated  # noqa: E402

cube = bpy.data.objects["Cube"]
sub = cube.modifiers.new("Sub", "SUBSURF")
sub.levels = 1
dg = evaluated()
assert dg == bpy.context.evaluated_depsgraph_get()
assert len(cube.evaluated_get(dg).data.vertices) == 26
sub.levels = 2  # tagged, not yet evaluated: evaluated() must bring it up to date
assert len(cube.evaluated_get(evaluated()).data.vertices) == 98

other = bpy.data.scenes.new("Other")
mesh = bpy.data.meshes.new("Tri")
mesh.from_pydata([(0, 0, 0), (1, 0, 0), (0, 1, 0)], [], [(0, 1, 2)])
tri = bpy.data.objects.new("Tri", mesh)
other.collection.objects.link(tri)
tri.modifiers.new("Sub", "SUBSURF").levels = 1
with bpy.context.temp_override(scene=other, view_layer=other.view_layers[0]):
    dg = evaluated(bpy.context)
    assert dg == bpy.context.evaluated_depsgraph_get()
    assert dg.scene == other
    assert len(tri.evaluated_get(dg).data.vertices) == 7
print("DEPSGRAPH EVALUATED OK")
