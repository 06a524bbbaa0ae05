"""The snow's depth is in world metres: the same 1 m slab modelled in metres and modelled in
centimetres with object scale 0.01 (as an FBX import gives it) renders equally deep snow."""
import math
import os

import bpy
import numpy as np

import in_blender

in_blender.enable()

tmp = in_blender.args()[0]
bpy.data.objects.remove(bpy.data.objects["Cube"])
bpy.ops.wm.save_as_mainfile(filepath=os.path.join(tmp, "displacement.blend"))
scene = bpy.context.scene
for name, size, scale, x in (("Metres", 1.0, 1.0, -0.6), ("Centimetres", 100.0, 0.01, 0.6)):
    bpy.ops.mesh.primitive_grid_add(x_subdivisions=24, y_subdivisions=24, size=size,
                                    location=(x, 0, 0))
    o = bpy.context.object
    o.name, o.scale = name, (scale,) * 3
    m = bpy.data.materials.new(name)
    m.use_nodes = True
    m.cycles.displacement_method = "DISPLACEMENT"
    o.data.materials.append(m)
    s = in_blender.snow(o, (1, 6), 48000, 64)
    s.snow.wind = (0.0, 0.0, 0.0)
    s.snow.depth_per_flake = 0.1
    assert bpy.ops.hydrobake.bake(effect="snow", object_name=name) == {"FINISHED"}
    disp = next(n for n in m.node_tree.nodes if n.get("hydrobake") == "snow.displacement")
    assert disp.space == "WORLD", disp.space
scene.frame_set(6)
cam = bpy.data.objects["Camera"]
cam.location, cam.rotation_euler = (0, -5, 0.15), (math.radians(90), 0, 0)
cam.data.type, cam.data.ortho_scale = "ORTHO", 2.4  # side view, 1 px = 1 cm
scene.render.engine = "CYCLES"
scene.cycles.samples, scene.cycles.use_denoising = 1, False
scene.render.film_transparent = True
scene.render.resolution_x, scene.render.resolution_y = 240, 80
scene.render.resolution_percentage = 100
scene.render.filepath = os.path.join(tmp, "side.png")
bpy.ops.render.render(write_still=True)
img = bpy.data.images.load(scene.render.filepath)
a = np.array(img.pixels[:]).reshape(80, 240, 4)[..., 3]
height = {n: int((a[:, c].max(axis=1) > 0.5).sum())
          for n, c in (("Metres", slice(20, 100)), ("Centimetres", slice(140, 220)))}
print("snow silhouette height in cm", height)
assert height["Metres"] >= 3, height  # the snow shows
assert abs(height["Metres"] - height["Centimetres"]) <= 1, height
print("SNOW DISPLACEMENT OK")
