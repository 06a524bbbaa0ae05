"""What the fluid pictures' scripts share: a fresh file with the addon on, boxes, plain
materials, and the bake's render (a camera, a sun, a grey-blue sky, Cycles at 32 samples)."""
import math
import os
import sys

import addon_utils
import bpy


def start(blend):
    """An empty file saved as ``blend`` in the output folder (the argument after "--"), the
    addon enabled; returns the folder."""
    out = os.path.abspath(sys.argv[sys.argv.index("--") + 1])
    bpy.ops.wm.read_factory_settings(use_empty=True)
    addon_utils.enable("hydrobake", default_set=True)
    bpy.ops.wm.save_as_mainfile(filepath=os.path.join(out, blend))
    return out


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


def floor(x, y):
    bpy.ops.mesh.primitive_plane_add(size=6, location=(x, y, 0.0))
    bpy.context.active_object.data.materials.append(material("Floor", (0.2, 0.22, 0.25, 1.0)))


def bake(tank, fill, obstacles, frames, resolution):
    """Bakes the SPH fluid of the domain ``tank`` filled from ``fill`` around the collection
    ``obstacles``, frames 1 to ``frames``."""
    s = tank.hydrobake_fluid
    s.enabled, s.fill_object, s.obstacles = True, fill, obstacles
    s.use_scene_range, s.frame_start, s.frame_end = False, 1, frames
    s.fluid.resolution = resolution
    bpy.context.scene.frame_set(1)
    assert bpy.ops.hydrobake.bake(effect="fluid", object_name=tank.name) == {"FINISHED"}


def render(frame, camera, tilt, size, path, turn=0.0):
    """Renders ``frame`` to ``path`` from a camera at ``camera`` tilted ``tilt`` degrees from
    looking down and turned ``turn`` degrees about z from looking along +y, ``size`` (width,
    height) pixels."""
    scene = bpy.context.scene
    scene.frame_set(frame)
    cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    scene.collection.objects.link(cam)
    cam.location, cam.rotation_euler = camera, (math.radians(tilt), 0.0, math.radians(turn))
    scene.camera = cam
    sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
    scene.collection.objects.link(sun)
    sun.rotation_euler = (math.radians(35), math.radians(-15), math.radians(20))
    sun.data.energy = 3.0
    scene.world = bpy.data.worlds.new("Sky")
    scene.world.use_nodes = True
    scene.world.node_tree.nodes["Background"].inputs["Color"].default_value = (0.4, 0.45, 0.55,
                                                                                1)
    scene.render.engine = "CYCLES"
    scene.cycles.samples, scene.cycles.use_denoising = 32, False
    scene.render.resolution_x, scene.render.resolution_y = size
    scene.render.filepath = path
    bpy.ops.render.render(write_still=True)
    print("RENDERED", scene.render.filepath)


def two_frames(frames, camera, tilt, out, name, turn=0.0):
    """Renders ``frames`` (two) as render() does, 400 x 330 each, side by side into
    OUT/name.png (each also as name_FRAME.png)."""
    halves = []
    for frame in frames:
        halves.append(_half(frame, camera, tilt, os.path.join(out, f"{name}_{frame}.png"),
                            first=not halves, turn=turn))
    side_by_side(halves, os.path.join(out, f"{name}.png"))


def _half(frame, camera, tilt, path, first, turn=0.0):
    """Renders ``frame`` to ``path``, 400 x 330, as render() does; the camera, sun and sky are
    made by the ``first`` only. Returns ``path``."""
    if first:
        render(frame, camera, tilt, (400, 330), path, turn)
    else:
        scene = bpy.context.scene
        scene.frame_set(frame)
        scene.render.filepath = path
        bpy.ops.render.render(write_still=True)
    return path


def side_by_side(paths, path):
    """The PNGs ``paths`` (all of one height) side by side, left to right, into ``path``."""
    import numpy as np
    imgs = [bpy.data.images.load(p) for p in paths]
    pix = [np.array(i.pixels[:], np.float32).reshape(i.size[1], i.size[0], 4) for i in imgs]
    both = np.concatenate(pix, axis=1)
    out = bpy.data.images.new("both", both.shape[1], both.shape[0], alpha=True)
    out.pixels[:] = both.ravel()
    out.filepath_raw, out.file_format = path, "PNG"
    out.save()
    print("SAVED", path)


def compared(tank, fill, obstacles, frame, resolution, cases, camera, tilt, out, name):
    """Bakes the domain ``tank`` (as bake()) to ``frame`` once for each (label, set) of
    ``cases``, set() changing the setting compared first, and renders that frame each time
    (as render(), 400 x 330) as OUT/name_LABEL.png, freeing each bake after; the renders side
    by side, left to right, into OUT/name.png."""
    halves = []
    for label, put in cases:
        put()
        bake(tank, fill, obstacles, frame, resolution)
        halves.append(_half(frame, camera, tilt, os.path.join(out, f"{name}_{label}.png"),
                            first=not halves))
        assert bpy.ops.hydrobake.free_bake(effect="fluid", object_name=tank.name) == \
            {"FINISHED"}
    side_by_side(halves, os.path.join(out, f"{name}.png"))
