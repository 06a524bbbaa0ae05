"""Renders docs/images/fluid_ring.png's halves: a block of water dropped over a ring (a torus
mesh, tilted a little) standing over the floor of a tank, the fluid textured and baked at 48
cells a side, rendered at frame 10 in Cycles. The right half as the addon bakes it since the
mesh obstacles (the ring is its shape: water falls through its hole and flows round its tube);
with ``box``, the left half: the ring taken as its own box, as before.

    BLENDER_USER_SCRIPTS=<dir holding addons/hydrobake> blender -b --factory-startup \\
        --python-exit-code 1 --python docs/scripts/fluid_ring.py -- OUTDIR [box]
"""
import math
import os
import sys
import time

import addon_utils
import bpy

out = os.path.abspath(sys.argv[sys.argv.index("--") + 1])
as_box = sys.argv[-1] == "box"
bpy.ops.wm.read_factory_settings(use_empty=True)
addon_utils.enable("hydrobake", default_set=True)
from hydrobake.blender.bridge import mesh_fields  # noqa: E402
if as_box:
    mesh_fields.mesh_shape = lambda *a: None
else:  # how long the field takes
    shape = mesh_fields.mesh_shape

    def timed(*a):
        t = time.perf_counter()
        s = shape(*a)
        print(f"FIELD {s.field.shape} in {time.perf_counter() - t:.2f} s")
        return s
    mesh_fields.mesh_shape = timed
bpy.ops.wm.save_as_mainfile(filepath=os.path.join(out, "box.blend" if as_box else "ring.blend"))
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


tank = box("Tank", (1.0, 1.0, 0.8), (0.5, 0.5, 0.4))
water = box("Water", (0.2, 0.2, 0.24), (0.5, 0.5, 0.66))
water.hide_render = True
bpy.ops.mesh.primitive_torus_add(major_radius=0.22, minor_radius=0.06, location=(0.5, 0.5, 0.3),
                                 rotation=(math.radians(12), 0.0, 0.0))
ring = bpy.context.active_object
bpy.ops.object.shade_smooth()
ring.data.materials.append(material("Brass", (0.6, 0.45, 0.15, 1.0), 0.3))
rings = bpy.data.collections.new("Rings")
scene.collection.children.link(rings)
rings.objects.link(ring)  # (also in the scene's collection: rendered)
bpy.ops.mesh.primitive_plane_add(size=6, location=(0.5, 0.5, 0.0))
bpy.context.active_object.data.materials.append(material("Floor", (0.2, 0.22, 0.25, 1.0)))

s = tank.hydrobake_fluid
s.enabled, s.fill_object, s.obstacles = True, water, rings
s.use_scene_range, s.frame_start, s.frame_end = False, 1, 10
s.fluid.resolution = (48, 48, 40)
scene.frame_set(1)
assert bpy.ops.hydrobake.bake(effect="fluid", object_name="Tank") == {"FINISHED"}

scene.frame_set(10)
cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
scene.collection.objects.link(cam)
cam.location, cam.rotation_euler = (0.5, -1.25, 0.95), (math.radians(66), 0.0, 0.0)
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
scene.render.resolution_x, scene.render.resolution_y = 480, 330
scene.render.filepath = os.path.join(out, "fluid_ring_box.png" if as_box else "fluid_ring.png")
bpy.ops.render.render(write_still=True)
print("RENDERED", scene.render.filepath)
