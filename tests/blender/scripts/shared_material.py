"""Two panes sharing one material, each with its own rain bake: each shows its own drops (the
second bake no longer rewires the first's material), and Free Bake gives the shared material
back once neither bake needs it."""
import math
import os

import bpy

import in_blender

in_blender.enable()
tmp = in_blender.args()[0]
bpy.ops.wm.save_as_mainfile(filepath=os.path.join(tmp, "panes.blend"))
shared = bpy.data.materials.new("SharedGlass")
shared.use_nodes = True


def pane(name, x):
    obj = in_blender.new_plane(name)
    obj.scale = (0.5, 0.5, 1.0)
    obj.location, obj.rotation_euler.x = (x, 0, 1), math.radians(60)
    obj.data.uv_layers.new(name="UVMap")
    obj.data.materials.append(shared)
    s = obj.hydrobake_rain
    s.enabled, s.rain.cell_size, s.use_scene_range = True, 0.01, False
    s.frame_start, s.frame_end = 1, 2
    return obj


def drops(obj):
    """The drop image the object's material shows, or None."""
    tree = obj.material_slots[0].material.node_tree
    node = next((n for n in tree.nodes if n.get("hydrobake") == "rain.normal"), None)
    return node.image.name if node else None


a, b = pane("PaneA", 0.0), pane("PaneB", 2.0)
for name in ("PaneA", "PaneB"):
    assert bpy.ops.hydrobake.bake(effect="rain", object_name=name) == {"FINISHED"}
assert a.material_slots[0].material.name == "SharedGlass (PaneA)"  # its own, as B uses it too
assert b.material_slots[0].material == shared  # B alone uses it now
assert drops(a) == "HBK_PaneA_rain_normal" and drops(b) == "HBK_PaneB_rain_normal"
assert bpy.ops.hydrobake.free_bake(effect="rain", object_name="PaneB") == {"FINISHED"}
assert drops(b) is None and drops(a) == "HBK_PaneA_rain_normal"  # A keeps its drops
assert bpy.ops.hydrobake.free_bake(effect="rain", object_name="PaneA") == {"FINISHED"}
assert a.material_slots[0].material == shared and drops(a) is None  # shared again
assert "SharedGlass (PaneA)" not in bpy.data.materials
print("SHARED MATERIAL OK")
