"""Windshield rain on glasses as artists make them: linked duplicates sharing one mesh, a
glass of several materials (a frit band), a Glass BSDF, a material with its own bump, a
switched-off Solidify, no material at all; a car keyed at a steady speed and one that turns;
a wiper keyed in quaternions; an 8-bit sRGB preview background; and layouts or settings the
bake must refuse by name (UVs outside 0..1, cells too coarse, a background with no file)."""
import math
import os

import bpy
import numpy as np
from mathutils import Quaternion

import in_blender

in_blender.enable()
from hydrobake.blender import jobs  # noqa: E402
from hydrobake.blender.bridge import materials  # noqa: E402
from hydrobake.core import exr  # noqa: E402
from hydrobake.core.bake.cache import frame_path  # noqa: E402

tmp = in_blender.empty_file("glass.blend")
scene = bpy.context.scene


def glass(name, x=0.0, mesh=None):
    if mesh is None:
        obj = in_blender.uv_plane(name)
        obj.scale = (0.5, 0.5, 1.0)
    else:
        obj = bpy.data.objects.new(name, mesh)
        scene.collection.objects.link(obj)
        obj.scale = (0.5, 0.5, 1.0)
    obj.location.x, obj.rotation_euler.x = x, math.radians(60)
    s = obj.hydrobake_rain
    s.enabled, s.use_scene_range, s.frame_start, s.frame_end = True, False, 1, 2
    s.rain.cell_size = 0.02
    return obj


def node_material(name, transmission=0.0):
    m = in_blender.node_material(name)
    materials.principled(m.node_tree).inputs["Transmission"].default_value = transmission
    return m


def bake(obj):
    assert bpy.ops.hydrobake.bake(effect="rain", object_name=obj.name) == {"FINISHED"}


def free(obj):
    assert bpy.ops.hydrobake.free_bake(effect="rain", object_name=obj.name) == {"FINISHED"}


def refused(obj):
    try:
        bpy.ops.hydrobake.bake(effect="rain", object_name=obj.name)
    except RuntimeError as exc:
        return str(exc)
    raise AssertionError(f"{obj.name}: not refused")


def drops(mat):
    n = materials.tagged(mat.node_tree, "rain.normal")
    return n.image.name if n is not None else None


# Linked duplicates: one mesh, two panes; each shows its own drops, and freeing one leaves
# the other's whole.
left = glass("Left", 0.0)
left.data.materials.append(node_material("Pane", 1.0))
right = glass("Right", 2.0, mesh=left.data)
bake(left)
bake(right)
assert drops(left.material_slots[0].material) == "HBK_Left_rain_normal"
assert drops(right.material_slots[0].material) == "HBK_Right_rain_normal"
free(right)
assert drops(left.material_slots[0].material) == "HBK_Left_rain_normal"
free(left)
assert [s.link for s in left.material_slots] == ["DATA"] and \
    left.material_slots[0].material.name == "Pane"
assert right.material_slots[0].material.name == "Pane" and drops(bpy.data.materials["Pane"]) \
    is None

# Two materials: both get the drops, the glass-like one (transmission) the glass values;
# a Glass BSDF is wired too; a material's own bump is kept for the inner face and given back.
two = glass("Two", 4.0)
frit, clear = node_material("Frit"), node_material("Clear", 1.0)
two.data.materials.append(frit)
two.data.materials.append(clear)
bump = clear.node_tree.nodes.new("ShaderNodeBump")
cbsdf = materials.principled(clear.node_tree)
clear.node_tree.links.new(bump.outputs["Normal"], cbsdf.inputs["Normal"])
bake(two)
assert drops(frit) and drops(clear)
assert materials.principled(frit.node_tree).inputs["Transmission"].default_value == 0.0
assert abs(cbsdf.inputs["IOR"].default_value - 1.33) < 1e-6
side = materials.tagged(clear.node_tree, "rain.side")
assert side.inputs["Color1"].links[0].from_node == bump
free(two)
assert cbsdf.inputs["Normal"].links[0].from_node == bump
assert abs(cbsdf.inputs["IOR"].default_value - 1.45) < 1e-6
gl = glass("GlassBSDF", 6.0)
gm = in_blender.node_material("GlassShader")
gm.node_tree.nodes.remove(materials.principled(gm.node_tree))
gnode = gm.node_tree.nodes.new("ShaderNodeBsdfGlass")
gm.node_tree.links.new(gnode.outputs[0], gm.node_tree.nodes["Material Output"].inputs[0])
gl.data.materials.append(gm)
bake(gl)
assert drops(gm) and gnode.inputs["Normal"].links[0].from_node.get("hydrobake") == "rain.side"
free(gl)

# A switched-off Solidify is no thickness: the bake adds its own. No material: one is made
# for the bake and gone with it, slot and all.
bare = glass("Bare", 8.0)
off = bare.modifiers.new("Off", "SOLIDIFY")
off.show_viewport = off.show_render = False
bake(bare)
assert [m.name for m in bare.modifiers] == ["Off", "HBK Glass Thickness"]
assert bare.material_slots[0].material.name == "HBK_Bare_glass"
free(bare)
assert [m.name for m in bare.modifiers] == ["Off"] and len(bare.material_slots) == 0
assert "HBK_Bare_glass" not in bpy.data.materials

# The car: keyed at a steady 15 m/s with linear keys (an instant start), and one that turns
# at 12 m/s: the speed along its own forward axis at each frame, the force within range.
car = bpy.data.objects.new("Car", None)
scene.collection.objects.link(car)
for f, loc, rz in ((1, (0, 0, 0), 0), (10, (0, 4.5, 0), 0), (11, (0.5, 5, 0), -90),
                   (20, (5, 5, 0), -90)):
    car.location, car.rotation_euler.z = loc, math.radians(rz)
    car.keyframe_insert("location", frame=f)
    car.keyframe_insert("rotation_euler", frame=f)
for fc in car.animation_data.action.fcurves:
    for k in fc.keyframe_points:
        k.interpolation = "LINEAR"
ws = glass("Windshield", 10.0)
w = ws.hydrobake_rain
w.car_object, w.frame_start, w.frame_end = car, 2, 18
fed = {}
for current in (3, 15):  # the frame the scene is on must not matter
    scene.frame_set(current)
    job = jobs.Job(bpy.context, ws, "rain")
    fed[current] = job.runner.effect.car
    job.runner.effect.close()
assert fed[3] == fed[15]
speeds = [round(fed[3][f][0], 1) for f in (5, 8, 13, 16)]
assert speeds == [12.0] * 4, speeds
assert max(abs(a) for _, a in fed[3].values()) <= 50.0
w.frame_start, w.frame_end = 1, 3  # from rest: 12 m/s in one frame, clamped, and bakes
bake(ws)
free(ws)

# A wiper keyed in quaternions: its turn about local Z drives the blade.
arm = bpy.data.objects.new("Arm", None)
scene.collection.objects.link(arm)
arm.rotation_mode = "QUATERNION"
for f, deg in ((1, 0.0), (12, 110.0)):
    arm.rotation_quaternion = Quaternion((0, 0, 1), math.radians(deg))
    arm.keyframe_insert("rotation_quaternion", frame=f)
w.car_object, w.frame_start, w.frame_end = None, 1, 12
w.rain.wiper_count, w.rain.wiper_mode, w.wiper_0 = 1, "PIVOT", arm
job = jobs.Job(bpy.context, ws, "rain")
angles = job.runner.effect.wipers
job.runner.effect.close()
assert abs(angles[1][0]) < 1e-3 and abs(angles[12][0] - 110.0) < 1e-3, angles
w.rain.wiper_count, w.wiper_0 = 0, None

# The preview background, an 8-bit sRGB image of grey 0.5, is 0.214 in linear light.
src = bpy.data.images.new("src", 16, 8)
src.pixels.foreach_set(np.tile([0.5, 0.5, 0.5, 1.0], 16 * 8).astype(np.float32))
src.filepath_raw, src.file_format = os.path.join(tmp, "street.png"), "PNG"
src.save()
w.background_image = bpy.data.images.load(os.path.join(tmp, "street.png"))
w.frame_end = 1
bake(ws)
v = float(np.median(exr.read(frame_path(w.bake_folder, "preview", 1, "exr"))["R"]))
assert abs(v - 0.214) < 0.01, v
free(ws)
w.background_image.filepath = os.path.join(tmp, "moved_away.png")
w.background_image.reload()
assert "Preview Background: image 'street.png' has no pixels" in refused(ws), refused(ws)
w.background_image = None

# Refused by name: UVs outside 0..1 (a UDIM tile), cells too coarse for the glass.
for loop in ws.data.uv_layers[0].data:
    loop.uv.x += 1.0
assert "its UV map 'UVMap' covers 0% of the 0..1 square" in refused(ws)
for loop in ws.data.uv_layers[0].data:
    loop.uv.x -= 1.0
w.rain.cell_size = 0.05  # 1 m glass / 0.05 m: 20 cells, fine; a 0.1 m glass is 2
ws.scale = (0.05, 0.05, 1.0)
assert "Cell Size = 0.05 m: gives 2 x 2 cells" in refused(ws), refused(ws)
print("RAIN GLASS CASES OK")
