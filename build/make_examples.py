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


def parts_object(scene, name, parts, location, smooth=()):
    """One mesh object from bmesh primitives: parts are (builder, material index); each part's
    UVs are packed into its own cell of the UV square so snow from different parts never
    shares texels."""
    import bmesh
    bm = bmesh.new()
    uv = bm.loops.layers.uv.new("UVMap")
    cells = int(math.ceil(math.sqrt(len(parts))))
    for k, (build, mat_index) in enumerate(parts):
        before = set(bm.faces)
        build(bm)
        cx, cy = k % cells, k // cells
        for f in set(bm.faces) - before:
            f.material_index = mat_index
            f.smooth = k in smooth
            for loop in f.loops:
                u, v = loop[uv].uv
                loop[uv].uv = ((cx + 0.02 + 0.96 * u) / cells, (cy + 0.02 + 0.96 * v) / cells)
    mesh = bpy.data.meshes.new(name)
    bm.to_mesh(mesh)
    bm.free()
    obj = bpy.data.objects.new(name, mesh)
    obj.location = location
    scene.collection.objects.link(obj)
    return obj


def cube(size, at):
    import bmesh
    from mathutils import Matrix

    def build(bm):
        m = Matrix.Translation(at) @ Matrix.Diagonal((*size, 1.0))
        bmesh.ops.create_cube(bm, size=1.0, matrix=m, calc_uvs=True)
    return build


def cylinder(radius, depth, at, axis="Z", segments=24):
    import bmesh
    from mathutils import Matrix

    def build(bm):
        rot = {"Z": Matrix.Identity(4), "Y": Matrix.Rotation(math.pi / 2, 4, "X"),
               "X": Matrix.Rotation(math.pi / 2, 4, "Y")}[axis]
        bmesh.ops.create_cone(bm, cap_ends=True, segments=segments, radius1=radius,
                              radius2=radius, depth=depth,
                              matrix=Matrix.Translation(at) @ rot, calc_uvs=True)
    return build


def sphere(radius, at):
    import bmesh
    from mathutils import Matrix

    def build(bm):
        bmesh.ops.create_uvsphere(bm, u_segments=24, v_segments=12, radius=radius,
                                  matrix=Matrix.Translation(at), calc_uvs=True)
    return build


def material(name, color, roughness=0.5, metallic=0.0, catch=None, melts=False, sheds=False):
    mat = bpy.data.materials.new(name)
    mat.use_nodes = True
    bsdf = mat.node_tree.nodes["Principled BSDF"]
    bsdf.inputs["Base Color"].default_value = (*color, 1)
    bsdf.inputs["Roughness"].default_value = roughness
    bsdf.inputs["Metallic"].default_value = metallic
    s = mat.hydrobake_snow
    if catch is not None:
        s.catch = catch
    s.melts, s.sheds = melts, sheds
    return mat


def snow_scene():
    """The paper's two subjects, a car (body, tyres) and a person (skin, coat, trousers,
    shoes), in falling snow with wind from -x."""
    scene = new_scene("Snow")
    scene.cycles.samples = 48
    scene.frame_start, scene.frame_end = 1, 48
    scene["hydrobake_still_frame"] = 48
    scene.world.node_tree.nodes["Background"].inputs["Color"].default_value = (0.55, 0.6, 0.7, 1)
    scene.world.node_tree.nodes["Background"].inputs["Strength"].default_value = 0.8
    ground = parts_object(scene, "Ground", [(cube((12.0, 10.0, 0.02), (0, 0, -0.01)), 0)],
                          (0.0, 0.0, 0.0))
    ground.data.materials.append(material("Asphalt", (0.08, 0.08, 0.09), 0.9))
    far = mesh_object(scene, "Far Ground", *grid(1, 60.0, lambda x, y: -0.03))
    far.data.materials.append(bpy.data.materials["Asphalt"])
    car = parts_object(scene, "Car", [
        (cube((3.8, 1.7, 0.7), (0, 0, 0.75)), 0),          # body
        (cube((2.0, 1.5, 0.55), (-0.2, 0, 1.35)), 0),       # cabin
        (cylinder(0.33, 0.25, (1.2, 0.85, 0.33), "Y"), 1),
        (cylinder(0.33, 0.25, (1.2, -0.85, 0.33), "Y"), 1),
        (cylinder(0.33, 0.25, (-1.3, 0.85, 0.33), "Y"), 1),
        (cylinder(0.33, 0.25, (-1.3, -0.85, 0.33), "Y"), 1),
    ], (-1.2, 0.6, 0))
    car.data.materials.append(material("Car Paint", (0.05, 0.12, 0.35), 0.15, 0.8, "SMOOTH"))
    car.data.materials.append(material("Tyre", (0.02, 0.02, 0.02), 0.8, sheds=True))
    person = parts_object(scene, "Person", [
        (sphere(0.12, (0, 0, 1.62)), 0),                     # head: skin
        (cylinder(0.2, 0.65, (0, 0, 1.17)), 1),              # coat
        (cylinder(0.075, 0.8, (0, 0.1, 0.46)), 2),           # trousers
        (cylinder(0.075, 0.8, (0, -0.1, 0.46)), 2),
        (cube((0.26, 0.11, 0.08), (0.05, 0.1, 0.04)), 3),    # shoes
        (cube((0.26, 0.11, 0.08), (0.05, -0.1, 0.04)), 3),
    ], (2.3, -1.2, 0), smooth=(0, 1, 2, 3))
    person.data.materials.append(material("Skin", (0.8, 0.6, 0.5), 0.5, melts=True))
    person.data.materials.append(material("Coat", (0.5, 0.1, 0.08), 0.9, 0, "COAT"))
    person.data.materials.append(material("Trousers", (0.1, 0.1, 0.15), 0.8, 0, "TROUSERS"))
    person.data.materials.append(material("Shoes", (0.15, 0.08, 0.03), 0.4, 0, "SHOES"))
    shelter = bpy.data.collections.new("Snow Shelter")  # the ground's snow sees car and person
    for o in (car, person):
        shelter.objects.link(o)
    ground.hydrobake_snow.colliders = shelter
    for obj in (car, person, ground):  # one snowfall: the same density in each Auto Volume
        s = obj.hydrobake_snow
        s.enabled = True
        s.flake_density = 6000.0
        s.snow.temperature = -1.0
        s.snow.wind = (2.0, 0.0, 0.0)
        s.snow.flake_radius = 0.004
        s.snow.texture_width = s.snow.texture_height = 1024
        s.snow.depth_per_flake = 0.0008
    sun_data = bpy.data.lights.new("Sun", "SUN")
    sun_data.energy = 2.0
    sun = bpy.data.objects.new("Sun", sun_data)
    sun.rotation_euler = (math.radians(40), math.radians(-20), math.radians(30))
    scene.collection.objects.link(sun)
    cam_data = bpy.data.cameras.new("Camera")
    cam_data.lens = 35
    cam = bpy.data.objects.new("Camera", cam_data)
    cam.location = (-4.5, -7.5, 3.2)
    cam.rotation_euler = (math.radians(72), 0, math.radians(-30))
    scene.collection.objects.link(cam)
    scene.camera = cam
    return scene


GLASS_W, GLASS_H, TILT = 1.4, 0.75, math.radians(35)


def glass_point(u, v):
    """World position of glass UV (u, v): a windshield tilted back TILT from the horizontal,
    its sides curving back towards the driver."""
    x = (u - 0.5) * GLASS_W
    s = v * GLASS_H
    y = 0.9 - s * math.cos(TILT) - 0.12 * (x / (GLASS_W / 2)) ** 2
    z = 0.95 + s * math.sin(TILT)
    return (x, y, z)


def wiper_angle(t, rest, sweep, period):
    return rest + sweep * (1 - math.cos(2 * math.pi * t / period)) / 2


def rain_scene():
    """A windshield with two animated wipers, seen from the driver's seat, a street outside."""
    import bmesh
    scene = new_scene("Rain")
    scene.frame_start, scene.frame_end = 1, 48
    scene["hydrobake_still_frame"] = 40  # the blades on their way back: rain ahead of them
    scene.cycles.samples = 48
    scene.render.resolution_x, scene.render.resolution_y = 960, 540
    scene.world.node_tree.nodes["Background"].inputs["Color"].default_value = (0.55, 0.6, 0.68, 1)
    scene.world.node_tree.nodes["Background"].inputs["Strength"].default_value = 1.0
    # The glass: a UV grid, u across, v up the glass.
    n_u, n_v = 28, 15
    bm = bmesh.new()
    uv = bm.loops.layers.uv.new("UVMap")
    verts = [[bm.verts.new(glass_point(i / n_u, j / n_v)) for i in range(n_u + 1)]
             for j in range(n_v + 1)]
    for j in range(n_v):
        for i in range(n_u):
            f = bm.faces.new((verts[j][i], verts[j][i + 1], verts[j + 1][i + 1], verts[j + 1][i]))
            f.smooth = True
            for loop, (a, b) in zip(f.loops, ((i, j), (i + 1, j), (i + 1, j + 1), (i, j + 1))):
                loop[uv].uv = (a / n_u, b / n_v)
    mesh = bpy.data.meshes.new("Windshield")
    bm.to_mesh(mesh)
    bm.free()
    glass = bpy.data.objects.new("Windshield", mesh)
    scene.collection.objects.link(glass)
    # Dashboard and frame, so the glass reads as a windshield.
    dash = mesh_object(scene, "Dashboard", *grid(1, 1.0, lambda x, y: 0.0))
    dash.scale = (1.6, 0.6, 1)
    dash.location = (0, 1.15, 0.93)
    dash.data.materials.append(material("Dashboard", (0.03, 0.03, 0.035), 0.6))
    # The cabin: A-pillars along the glass's sides and the roof's edge above it.
    trim = material("Cabin Trim", (0.02, 0.02, 0.025), 0.7)
    for k, u in enumerate((0.0, 1.0)):
        a, b = glass_point(u, 0.0), glass_point(u, 1.0)
        mid = tuple((p + q) / 2 for p, q in zip(a, b))
        pillar = parts_object(scene, f"A-Pillar {k}", [(cube((0.08, 0.8, 0.05), (0, 0, 0)), 0)],
                              mid)
        pillar.rotation_euler = (-TILT, 0, 0)
        pillar.location.x += -0.04 if u == 0.0 else 0.04
        pillar.data.materials.append(trim)
    top = glass_point(0.5, 1.0)
    roof = parts_object(scene, "Roof", [(cube((1.6, 1.2, 0.04), (0, 0, 0)), 0)],
                        (0.0, top[1] - 0.6, top[2] + 0.03))
    roof.data.materials.append(trim)
    # Outside: a road, buildings, a car ahead.
    road = mesh_object(scene, "Road", *grid(1, 200.0, lambda x, y: 0.0))
    road.data.materials.append(material("Road", (0.05, 0.05, 0.055), 0.4))
    colours = [(0.6, 0.2, 0.15), (0.2, 0.35, 0.6), (0.75, 0.65, 0.4), (0.3, 0.5, 0.3),
               (0.7, 0.7, 0.72), (0.5, 0.25, 0.45)]
    for k in range(10):
        side = -1 if k % 2 else 1
        b = parts_object(scene, f"Building {k}", [(cube((6, 6, 6 + 3 * (k % 4)),
                                                        (0, 0, 3 + 1.5 * (k % 4))), 0)],
                         (side * (9 + (k % 3)), 12 + 9 * k, 0))
        b.data.materials.append(material(f"Facade {k}", colours[k % len(colours)], 0.7))
    ahead = parts_object(scene, "Car Ahead", [(cube((1.8, 4.2, 1.0), (0, 0, 0.75)), 0),
                                              (cube((1.6, 2.0, 0.6), (0, -0.3, 1.5)), 0)],
                         (0.6, 14.0, 0))
    ahead.data.materials.append(material("Red Paint", (0.6, 0.02, 0.02), 0.25, 0.6))
    lamp = parts_object(scene, "Tail Lights", [(cube((1.6, 0.05, 0.12), (0, -2.12, 0.95)), 0)],
                        (0.6, 14.0, 0))
    em = bpy.data.materials.new("Tail Light")
    em.use_nodes = True
    em.node_tree.nodes["Principled BSDF"].inputs["Emission"].default_value = (1, 0.05, 0.02, 1)
    em.node_tree.nodes["Principled BSDF"].inputs["Emission Strength"].default_value = 8.0
    lamp.data.materials.append(em)
    sun_data = bpy.data.lights.new("Overcast", "SUN")
    sun_data.energy = 1.5
    sun_data.angle = math.radians(30)
    sun = bpy.data.objects.new("Overcast", sun_data)
    sun.rotation_euler = (math.radians(30), 0, math.radians(20))
    scene.collection.objects.link(sun)
    cam_data = bpy.data.cameras.new("Driver")
    cam_data.lens = 28
    cam = bpy.data.objects.new("Driver", cam_data)
    cam.location = (-0.25, -0.05, 1.14)
    cam.rotation_euler = (math.radians(84), 0, math.radians(4))
    scene.collection.objects.link(cam)
    scene.camera = cam
    # Wipers: the simulation's PIVOT blades, and objects that follow the same angles.
    s = glass.hydrobake_rain
    s.enabled = True
    s.substeps = 2
    r = s.rain
    r.cell_size = 0.002
    # A steady shower: distinct drops, and the blades' sweeps stay clear for a moment.
    r.rain_rate = 3000.0
    r.drop_mass = 15.0
    r.trail_mass = 1.0  # trail beads a few texels wide, not single-texel specks
    r.trail_spacing = 0.006
    r.height_scale = 0.0022  # caps of ~60 degrees, as on clean glass: lenses, not beads
    r.radius_scale = 1.25
    r.wiper_count, r.wiper_mode = 2, "PIVOT"
    r.wiper_pivot = (0.30, -0.03, 0.95, -0.03)
    r.wiper_rest = (8.0, 8.0)
    r.sweep_angle = 110.0
    r.blade_length, r.blade_offset = 0.5, 0.06
    r.wiper_period = 2.0
    fps = scene.render.fps
    blade_mat = material("Wiper", (0.01, 0.01, 0.01), 0.5)
    for w in range(2):
        px, py = r.wiper_pivot[2 * w], r.wiper_pivot[2 * w + 1]
        blade = parts_object(scene, f"Wiper {w}", [(cube((r.blade_length, 0.012, 0.02),
                                                         (r.blade_offset + r.blade_length / 2,
                                                          0, 0)), 0)], (0, 0, 0))
        blade.data.materials.append(blade_mat)
        origin = glass_point(px / GLASS_W, max(py, 0.0) / GLASS_H)
        out = (0.0, math.sin(TILT), math.cos(TILT))  # the glass's outward normal
        blade.location = tuple(o + 0.012 * n for o, n in zip(origin, out))
        # Local x = u, local y = up the glass: R = Rx(pi - TILT) Rz(theta) ("ZYX" order).
        blade.rotation_mode = "ZYX"
        for f in range(scene.frame_start, scene.frame_end + 1):
            t = (f - scene.frame_start + 1) / fps
            theta = math.radians(wiper_angle(t, r.wiper_rest[w], r.sweep_angle, r.wiper_period))
            blade.rotation_euler = (math.pi - TILT, 0.0, theta)
            blade.keyframe_insert("rotation_euler", frame=f)
        setattr(s, f"wiper_{w}", blade)  # the animation drives the simulated blade
    return scene


def fluid_scene():
    """A dam break with the paper's three sample textures: waves wherever the flow accelerates
    hard and noise again where it has settled (two feature rules, far apart, so a region keeps
    its waves while it calms down), cells painted into the column before it falls (local paint,
    carried along by the flow)."""
    scene = new_scene("Fluid")
    scene.frame_start, scene.frame_end = 1, 36
    scene["hydrobake_still_frame"] = 30
    scene.cycles.samples = 32
    tank = parts_object(scene, "Tank", [(cube((1.2, 0.5, 0.6), (0.6, 0.25, 0.3)), 0)], (0, 0, 0))
    tank.display_type = "BOUNDS"
    column = parts_object(scene, "Water Column", [(cube((0.3, 0.46, 0.45), (0.17, 0.25, 0.24)), 0)],
                          (0, 0, 0))
    column.hide_render = True
    column.display_type = "WIRE"
    floor = mesh_object(scene, "Floor", *grid(1, 6.0, lambda x, y: -0.001))
    floor.data.materials.append(material("Floor", (0.35, 0.35, 0.38), 0.6))
    s = tank.hydrobake_fluid
    s.enabled, s.fill_object = True, column
    s.fluid.resolution = (96, 40, 48)  # 1.25 cm voxels: droplets round, not diamonds
    s.fluid.particle_spacing = 0.02
    s.fluid.smoothing_length = 0.04
    s.fluid.metaball_radius = 0.035
    s.fluid.substeps = 16
    s.fluid.textures = 3
    s.fluid.reset_period = 1.0
    s.fluid.max_flow = 8.0  # voxels a frame: the wave runs at 2-3 m/s, 7-10 voxels a frame
    rule = s.rules.add()
    rule.texture, rule.feature, rule.low, rule.high = 1, "ACCELERATION", 30.0, 1e9
    rule = s.rules.add()  # settled: the calmest quarter of the water at rest on the floor
    rule.texture, rule.feature, rule.low, rule.high = 0, "ACCELERATION", 0.0, 2.0
    brush = bpy.data.objects.new("Paint Brush", None)
    # The column's front top, facing the camera: the painted cells ride the wave's face.
    brush.empty_display_type, brush.empty_display_size = "SPHERE", 0.2
    brush.location = (0.22, 0.08, 0.38)
    strokes = bpy.data.collections.new("Fluid Paint")
    scene.collection.children.link(strokes)
    strokes.objects.link(brush)
    brush.hydrobake_fluid_paint.enabled = True
    brush.hydrobake_fluid_paint.texture, brush.hydrobake_fluid_paint.frame = 2, 1
    s.paint_collection = strokes
    s.fluid.paint_duration, s.fluid.paint_fade = 2.0, 1.0
    sun_data = bpy.data.lights.new("Key", "SUN")
    sun_data.energy = 3.0
    sun = bpy.data.objects.new("Key", sun_data)
    sun.rotation_euler = (math.radians(45), 0, math.radians(35))
    scene.collection.objects.link(sun)
    cam_data = bpy.data.cameras.new("Camera")
    cam_data.lens = 40
    cam = bpy.data.objects.new("Camera", cam_data)
    cam.location = (0.6, -1.6, 0.75)
    cam.rotation_euler = (math.radians(70), 0, 0)
    scene.collection.objects.link(cam)
    scene.camera = cam
    return scene


clear()
scenes = [caustics_scene(), snow_scene(), rain_scene(), fluid_scene()]
bpy.context.preferences.filepaths.save_version = 0  # no examples.blend1 beside it
bpy.ops.wm.save_as_mainfile(filepath=out, compress=True)
print("examples written:", out, [s.name for s in scenes])
