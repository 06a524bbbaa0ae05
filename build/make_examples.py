"""Builds examples.blend: one scene per effect, ready to bake (run by Blender with the addon
enabled; see build/make_examples.sh). Re-run it when an effect's example changes."""
import math
import sys

import addon_utils
import bpy

addon_utils.enable("hydrobake", default_set=False)
out = sys.argv[sys.argv.index("--") + 1]


def clear():
    for scene in list(bpy.data.scenes)[1:]:
        bpy.data.scenes.remove(scene)
    for coll in (bpy.data.objects, bpy.data.meshes, bpy.data.materials, bpy.data.lights,
                 bpy.data.cameras, bpy.data.images, bpy.data.worlds):
        for block in list(coll):
            coll.remove(block)


def new_scene(name):
    scene = bpy.data.scenes[0] if bpy.data.scenes[0].name == "Scene" else bpy.data.scenes.new(name)
    scene.name = name
    scene.render.engine = "CYCLES"
    scene.cycles.device = "CPU"
    scene.cycles.samples = 128
    scene.cycles.use_denoising = False  # Debian's Cycles has no denoiser
    # Hydrobake supplies the caustics; Cycles' own (noisy, no denoiser) are switched off.
    scene.cycles.caustics_refractive = False
    scene.cycles.caustics_reflective = False
    scene.cycles.sample_clamp_indirect = 3.0
    scene.render.resolution_x, scene.render.resolution_y = 640, 360
    scene.render.film_transparent = False
    world = bpy.data.worlds.new(f"{name} World")
    world.use_nodes = True
    world.node_tree.nodes["Background"].inputs["Color"].default_value = (0.5, 0.6, 0.75, 1)
    world.node_tree.nodes["Background"].inputs["Strength"].default_value = 0.3
    scene.world = world
    return scene


def mesh_object(scene, name, verts, faces):
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata(verts, [], faces)
    mesh.update()
    obj = bpy.data.objects.new(name, mesh)
    scene.collection.objects.link(obj)
    return obj


def grid(n, size, z_of):
    verts = [((i / n - 0.5) * size, (j / n - 0.5) * size, 0.0) for j in range(n + 1)
             for i in range(n + 1)]
    verts = [(x, y, z_of(x, y)) for x, y, _ in verts]
    faces = [(j * (n + 1) + i, j * (n + 1) + i + 1, (j + 1) * (n + 1) + i + 1,
              (j + 1) * (n + 1) + i) for j in range(n) for i in range(n)]
    return verts, faces


def tiles_material(name):
    mat = bpy.data.materials.new(name)
    mat.use_nodes = True
    nt = mat.node_tree
    bsdf = nt.nodes["Principled BSDF"]
    brick = nt.nodes.new("ShaderNodeTexBrick")
    brick.inputs["Color1"].default_value = (0.55, 0.78, 0.85, 1)
    brick.inputs["Color2"].default_value = (0.45, 0.70, 0.80, 1)
    brick.inputs["Mortar"].default_value = (0.9, 0.95, 0.95, 1)
    brick.inputs["Scale"].default_value = 12.0
    brick.inputs["Mortar Size"].default_value = 0.02
    brick.offset = 0.0
    brick.location = (-400, 300)
    coord = nt.nodes.new("ShaderNodeTexCoord")
    coord.location = (-600, 300)
    nt.links.new(coord.outputs["Object"], brick.inputs["Vector"])
    nt.links.new(brick.outputs["Color"], bsdf.inputs["Base Color"])
    bsdf.inputs["Roughness"].default_value = 0.6
    return mat


def caustics_scene():
    scene = new_scene("Caustics")
    scene.frame_start, scene.frame_end = 1, 24
    scene["hydrobake_still_frame"] = 24
    # A 4 m x 4 m pool whose floor slopes from 1.2 m deep to 0.35 m.
    floor = mesh_object(scene, "Pool Floor", *grid(32, 4.0, lambda x, y: -0.775 + 0.2125 * x))
    floor.data.materials.append(tiles_material("Pool Tiles"))
    walls = []
    for k, (cx, cy, sx, sy) in enumerate(((0, 2.05, 4.2, 0.1), (0, -2.05, 4.2, 0.1),
                                          (2.05, 0, 0.1, 4.0), (-2.05, 0, 0.1, 4.0))):
        v = [(cx + dx * sx / 2, cy + dy * sy / 2, z) for z in (-1.3, 0.15)
             for dx, dy in ((-1, -1), (1, -1), (1, 1), (-1, 1))]
        f = [(0, 1, 2, 3), (4, 7, 6, 5), (0, 4, 5, 1), (1, 5, 6, 2), (2, 6, 7, 3), (3, 7, 4, 0)]
        walls.append(mesh_object(scene, f"Pool Wall {k}", v, f))
    wall_mat = bpy.data.materials.new("Pool Coping")
    wall_mat.use_nodes = True
    wall_mat.node_tree.nodes["Principled BSDF"].inputs["Base Color"].default_value = (0.85, 0.83, 0.78, 1)
    for w in walls:
        w.data.materials.append(wall_mat)
    water = mesh_object(scene, "Water", *grid(1, 4.0, lambda x, y: 0.0))
    # A ball rolling across the pool, half in the water.
    ball_v, ball_f = [], []
    n, m = 24, 12
    for j in range(m + 1):
        th = math.pi * j / m
        for i in range(n):
            ph = 2 * math.pi * i / n
            ball_v.append((0.25 * math.sin(th) * math.cos(ph), 0.25 * math.sin(th) * math.sin(ph),
                           0.25 * math.cos(th)))
    for j in range(m):
        for i in range(n):
            a, b = j * n + i, j * n + (i + 1) % n
            ball_f.append((a, b, b + n, a + n))
    ball = mesh_object(scene, "Beach Ball", ball_v, ball_f)
    for p in ball.data.polygons:
        p.use_smooth = True
    ball_mat = bpy.data.materials.new("Beach Ball")
    ball_mat.use_nodes = True
    ball_mat.node_tree.nodes["Principled BSDF"].inputs["Base Color"].default_value = (0.9, 0.25, 0.1, 1)
    ball.data.materials.append(ball_mat)
    for frame, x, y in ((1, -1.5, -1.0), (24, 1.2, 0.8)):
        ball.location = (x, y, 0.08)
        ball.keyframe_insert("location", frame=frame)
    for fc in ball.animation_data.action.fcurves:
        for kp in fc.keyframe_points:
            kp.interpolation = "LINEAR"
    sun_data = bpy.data.lights.new("Sun", "SUN")
    sun_data.energy = 4.0
    sun_data.angle = math.radians(0.5)  # a sharp sun makes sharp caustics
    sun = bpy.data.objects.new("Sun", sun_data)
    sun.rotation_euler = (math.radians(20), math.radians(10), 0)
    scene.collection.objects.link(sun)
    cam_data = bpy.data.cameras.new("Camera")
    cam_data.lens = 28
    cam = bpy.data.objects.new("Camera", cam_data)
    cam.location = (0.0, -4.6, 3.4)
    cam.rotation_euler = (math.radians(50), 0, 0)
    scene.collection.objects.link(cam)
    scene.camera = cam

    s = water.hydrobake_caustics
    s.enabled = True
    s.ground_object, s.disturber_object, s.sun_object = floor, ball, sun
    s.disturber_depth = 0.12
    s.map_resolution = 1024
    s.water.width = 256
    s.water.rain_rate = 30.0
    s.water.rain_radius = 0.04
    s.water.rain_depth = 0.01
    s.water.substeps = 4
    s.water.implicitness = 0.55
    s.light.absorption = (0.35, 0.06, 0.01)
    return scene


clear()
scenes = [caustics_scene()]
bpy.ops.wm.save_as_mainfile(filepath=out, compress=True)
print("examples written:", out, [s.name for s in scenes])
