"""A pool turned about z: the water grid is the pool's own rectangle (not its bounding box),
a disturber's dent lands in the cell under it, and what the bake wires reads the maps where
they belong. Two probes rendered by Cycles from above check the wiring in Blender's own
shading: the floor's map lookup gives the point's place on the grid (u / width, v / height),
and the water's normals are the map's, turned with the pool into the world."""
import math
import os

import bpy
import numpy as np

import in_blender

in_blender.enable()
from hydrobake.core import exr  # noqa: E402
from hydrobake.core.bake.cache import frame_path  # noqa: E402

tmp = in_blender.empty_file("turned.blend")
scene = bpy.context.scene
ANGLE = math.radians(30.0)
pool = in_blender.new_plane("Pool")  # 2 m x 1 m, turned 30 degrees, centred at (1, 2)
pool.scale = (1.0, 0.5, 1.0)
pool.rotation_euler = (0.0, 0.0, ANGLE)
pool.location = (1.0, 2.0, 0.0)
floor = in_blender.new_plane("Floor")
floor.scale, floor.location = (4.0, 4.0, 1.0), (1.0, 2.0, -0.5)
floor.data.materials.append(bpy.data.materials.new("Floor"))
floor.data.materials[0].use_nodes = True
pool.data.materials.append(bpy.data.materials.new("Water"))
pool.data.materials[0].use_nodes = True
c, s = math.cos(ANGLE), math.sin(ANGLE)


def world(u, v):
    """The pool's corner is its local (-1, -0.5); u, v in metres along its sides."""
    lx, ly = u - 1.0, v - 0.5
    return 1.0 + c * lx - s * ly, 2.0 + s * lx + c * ly


stone = in_blender.new_box("Stone", (0.2, 0.2, 0.2), (*world(1.5, 0.75), 0.05))  # through
# the surface, its 0.2 m square footprint at grid (1.5, 0.75) m, its underside 0.05 m down
settings = pool.hydrobake_caustics
settings.enabled, settings.ground_object = True, floor
settings.disturber_object, settings.disturber_depth = stone, 0.05
settings.use_scene_range, settings.frame_start, settings.frame_end = False, 1, 2
settings.water.width, settings.map_resolution, settings.water.rain_rate = 64, 128, 0.0
settings.displace_surface, settings.projector = True, True
sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
scene.collection.objects.link(sun)
sun.rotation_euler = (math.radians(20.0), 0.0, 0.0)  # towards the sun: (0, -sin 20, cos 20)
settings.sun_object = sun
assert bpy.ops.hydrobake.bake(effect="caustics", object_name="Pool") == {"FINISHED"}
folder = settings.bake_folder
params = __import__("json").load(open(os.path.join(folder, "manifest.json")))["params"]
p = params["water"]
# The sun's direction in the grid's frame: world (0, -sin 20, cos 20) turned by -30 degrees.
d = params["light"]["light_direction"]
up = math.radians(20.0)
want = (-math.sin(up) * s, -math.sin(up) * c, math.cos(up))
assert max(abs(a - b) for a, b in zip(d, want)) < 1e-5, (d, want)
# The displacement reads the grid through an Empty spanning it: the pool's corners are its
# -1..1 corners (the image's 0..1); the displaced surface dips under the stone.
grid_frame = bpy.data.objects["HBK_Pool_grid"]
inv = grid_frame.matrix_world.inverted()
for v in pool.data.vertices:
    local = inv @ (pool.matrix_world @ v.co)
    assert max(abs(abs(local.x) - 1.0), abs(abs(local.y) - 1.0)) < 1e-5, tuple(local)
bpy.context.scene.frame_set(2)
dg = bpy.context.evaluated_depsgraph_get()
ev = pool.evaluated_get(dg).to_mesh()
low = min(ev.vertices, key=lambda v: v.co.z)
at = pool.matrix_world @ low.co
assert at.z < -0.01 and math.hypot(at.x - stone.location.x, at.y - stone.location.y) < 0.15, \
    (tuple(at), tuple(stone.location))
pool.evaluated_get(dg).to_mesh_clear()
# The projector above the pool's centre, turned with it.
proj = bpy.data.objects["HBK_Pool_projector"]
assert abs(proj.location.x - 1.0) < 1e-5 and abs(proj.location.y - 2.0) < 1e-5
assert abs(proj.rotation_euler.z - ANGLE) < 1e-6
proj.hide_render = True
# The pool's 2 x 1 m in 64 columns: 32 rows of 1/32 m (its bounding box would be 2.23 x 1.87).
assert p["height"] == 32 and abs(p["cell_size"] - 2.0 / 64) < 1e-6, p
height = exr.read(frame_path(folder, "water", 1, "exr"))["height"]
jj, ii = np.nonzero(height < 0.5 * height.min())  # the dent: centred under the stone
assert abs(ii.mean() - 47.5) < 1 and abs(jj.mean() - 23.5) < 1, (ii.mean(), jj.mean())
stone.hide_render = True

# Probes: an orthographic camera looking straight down on the pool, one sample, no filter.
cam = bpy.data.objects.new("Top", bpy.data.cameras.new("Top"))
scene.collection.objects.link(cam)
cam.data.type, cam.data.ortho_scale = "ORTHO", 3.0
cam.location = (1.0, 2.0, 5.0)
scene.camera = cam
r = scene.render
r.engine, r.resolution_x, r.resolution_y, r.resolution_percentage = "CYCLES", 48, 48, 100
r.filter_size = 0.01
scene.cycles.samples, scene.cycles.use_denoising = 1, False
scene.view_settings.view_transform = "Standard"
r.image_settings.file_format, r.image_settings.color_depth = "OPEN_EXR", "32"
scene.frame_set(1)


def probe(obj, tag, name):
    """Renders ``obj``'s material showing the vector output of its node tagged ``tag`` as
    emission (as v * 0.5 + 0.5, so no value is negative); returns the vectors at the pixels
    (rows from the bottom) and each pixel centre's world x and y."""
    tree = obj.active_material.node_tree
    node = next(n for n in tree.nodes if n.get("hydrobake") == tag)
    out = next(n for n in tree.nodes if n.type == "OUTPUT_MATERIAL" and n.is_active_output)
    keep = out.inputs["Surface"].links[0].from_socket
    half = tree.nodes.new("ShaderNodeVectorMath")
    half.operation = "MULTIPLY_ADD"
    half.inputs[1].default_value = half.inputs[2].default_value = (0.5, 0.5, 0.5)
    emit = tree.nodes.new("ShaderNodeEmission")
    tree.links.new(node.outputs[0], half.inputs[0])
    tree.links.new(half.outputs[0], emit.inputs["Color"])
    tree.links.new(emit.outputs["Emission"], out.inputs["Surface"])
    r.filepath = os.path.join(tmp, name)
    bpy.ops.render.render(write_still=True)
    tree.links.new(keep, out.inputs["Surface"])
    tree.nodes.remove(emit)
    tree.nodes.remove(half)
    img = bpy.data.images.load(r.filepath)
    px = np.array(img.pixels[:], np.float64).reshape(48, 48, 4)[..., :3] * 2.0 - 1.0
    at = (np.arange(48) + 0.5) / 48 * 3.0 - 1.5
    return px, at[None, :] + 1.0, at[:, None] + 2.0


# The floor's lookup: the point's place on the grid, u / 2 m and v / 1 m, wherever it is.
pool.hide_render = True
px, x, y = probe(floor, "caustics.map.mapping", "floor.exr")
u = c * (x - world(0, 0)[0]) + s * (y - world(0, 0)[1])
v = -s * (x - world(0, 0)[0]) + c * (y - world(0, 0)[1])
du, dv = np.abs(px[..., 0] - u / 2.0), np.abs(px[..., 1] - v / 1.0)
assert du.max() < 2e-3 and dv.max() < 2e-3, (du.max(), dv.max())
pool.hide_render = False

# The water's normals: the map's (in the grid's frame) turned by 30 degrees into the world.
px, x, y = probe(pool, "caustics.normal_turn", "water.exr")
surface = exr.read(frame_path(folder, "surface", 1, "exr"))
n_grid = np.stack([surface[k] for k in ("R", "G", "B")], -1) * 2.0 - 1.0
u = c * (x - world(0, 0)[0]) + s * (y - world(0, 0)[1])
v = -s * (x - world(0, 0)[0]) + c * (y - world(0, 0)[1])
inside = (u > 0.1) & (u < 1.9) & (v > 0.1) & (v < 0.9)
cell = 2.0 / 64
ci = np.clip((u / cell).astype(int), 0, 63)[inside]
cj = np.clip((v / cell).astype(int), 0, 31)[inside]
want = n_grid[cj, ci]
want /= np.linalg.norm(want, axis=-1, keepdims=True)
want = np.stack([c * want[:, 0] - s * want[:, 1], s * want[:, 0] + c * want[:, 1],
                 want[:, 2]], -1)
got = px[inside]
tilt = np.hypot(want[:, 0], want[:, 1])
assert inside.sum() > 300 and tilt.max() > 0.02, (inside.sum(), tilt.max())  # a real dent
# Within a cell the texture interpolates, so compare where the dent tilts the surface: the
# heading of the tilt is the map's turned by 30 degrees (unturned, it is 30 degrees off).
err = np.abs(got - want).max(axis=-1)
assert np.median(err) < 0.01, np.median(err)
steep = tilt > 0.1
off = np.degrees(np.abs(np.angle(np.exp(1j * (np.arctan2(got[steep, 1], got[steep, 0]) -
                                              np.arctan2(want[steep, 1], want[steep, 0]))))))
assert steep.sum() >= 10 and np.median(off) < 12.0, (steep.sum(), np.median(off))
print("CAUSTICS TURNED OK", int(inside.sum()), int(steep.sum()), float(np.median(off)))
