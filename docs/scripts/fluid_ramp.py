"""Renders docs/images/fluid_ramp.png's halves: a block of water dropped onto a board tilted
20 degrees (a still obstacle), the fluid textured and baked at 64 cells along the tank,
rendered at frame 18 in Cycles. The right half as the addon bakes it since the turned boxes
(the board is its own box, turned with it); with ``box``, the left half: the board taken as
its world bounding box, as every obstacle was before.

    BLENDER_USER_SCRIPTS=<dir holding addons/hydrobake> blender -b --factory-startup \\
        --python-exit-code 1 --python docs/scripts/fluid_ramp.py -- OUTDIR [box]
"""
import math
import os
import sys

import addon_utils
import bpy

out = os.path.abspath(sys.argv[sys.argv.index("--") + 1])
as_box = sys.argv[-1] == "box"
bpy.ops.wm.read_factory_settings(use_empty=True)
addon_utils.enable("hydrobake", default_set=True)
if as_box:
    from hydrobake.blender.bridge import meshes
    meshes.turned_bounds = lambda obj: None
bpy.ops.wm.save_as_mainfile(filepath=os.path.join(out, "box.blend" if as_box else "ramp.blend"))
scene = bpy.context.scene


def box(name, size, location):
    bpy.ops.mesh.primitive_cube_add(size=1.0, location=location)
    obj = bpy.context.active_object
    obj.name, obj.scale = name, size
    return obj


def material(name, colour, roughness=0.6):
    mat = bpy.data.materials.new(name)
    mat.use_nodes = True
    bsdf = mat.node_tree.nodes["Principled BSDF"]
    bsdf.inputs["Base Color"].default_value = colour
    bsdf.inputs["Roughness"].default_value = roughness
    return mat


tank = box("Tank", (1.6, 0.6, 0.6), (0.8, 0.3, 0.3))
water = box("Water", (0.34, 0.6, 0.16), (0.19, 0.3, 0.5))
water.hide_render = True
ramp = box("Ramp", (1.0, 0.6, 0.04), (0.55, 0.3, 0.22))
ramp.rotation_euler.y = math.radians(20.0)  # its +x end down
ramp.data.materials.append(material("Wood", (0.35, 0.18, 0.07, 1.0)))
boards = bpy.data.collections.new("Boards")
scene.collection.children.link(boards)
boards.objects.link(ramp)  # (also in the scene's collection: rendered)
bpy.ops.mesh.primitive_plane_add(size=6, location=(0.8, 0.3, 0.0))
bpy.context.active_object.data.materials.append(material("Floor", (0.2, 0.22, 0.25, 1.0)))

s = tank.hydrobake_fluid
s.enabled, s.fill_object, s.obstacles = True, water, boards
s.use_scene_range, s.frame_start, s.frame_end = False, 1, 18
s.fluid.resolution = (64, 24, 24)
scene.frame_set(1)
assert bpy.ops.hydrobake.bake(effect="fluid", object_name="Tank") == {"FINISHED"}

scene.frame_set(18)
cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
scene.collection.objects.link(cam)
cam.location, cam.rotation_euler = (0.8, -1.5, 1.5), (math.radians(52), 0.0, 0.0)
scene.camera = cam
sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
scene.collection.objects.link(sun)
sun.rotation_euler = (math.radians(35), math.radians(-15), math.radians(20))
sun.data.energy = 3.0
scene.world = bpy.data.worlds.new("Sky")
scene.world.use_nodes = True
scene.world.node_tree.nodes["Background"].inputs["Color"].default_value = (0.4, 0.45, 0.55, 1)
scene.render.engine = "CYCLES"
scene.cycles.samples, scene.cycles.use_denoising = 32, False
scene.render.resolution_x, scene.render.resolution_y = 480, 300
scene.render.filepath = os.path.join(out, "fluid_ramp_box.png" if as_box else "fluid_ramp.png")
bpy.ops.render.render(write_still=True)
print("RENDERED", scene.render.filepath)
