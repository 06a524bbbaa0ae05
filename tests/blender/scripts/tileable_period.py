"""The built-in sample textures' tileable groups repeat every uvw unit, without a seam: a strip
x in [0, 2] rendered (emission, orthographic, one sample at each pixel's centre) shows the
same colours at x and x + 1, and crossing x = 1 changes the colour no more than a step
inside a tile does. The plain texture does not repeat, and the plain texture at frac(uvw)
repeats with a seam at x = 1 (so both checks can fail; the seam shows clearly in the smooth
noise)."""
import os

import bpy
import numpy as np

import in_blender

in_blender.enable()
from hydrobake.blender.bridge import tileable  # noqa: E402

tmp = in_blender.args()[0]
scene = bpy.context.scene
for obj in list(scene.objects):  # the startup file's cube, light and camera
    bpy.data.objects.remove(obj)
scene.world = None  # black behind
scene.render.engine = "CYCLES"
scene.cycles.samples = 1
scene.cycles.use_denoising = False
scene.cycles.pixel_filter_type = "BOX"
scene.render.filter_size = 0.01  # the sample at the pixel's centre
scene.cycles.seed = 0
W, H = 64, 8  # 32 pixels per uvw unit
scene.render.resolution_x, scene.render.resolution_y = W, H
scene.render.resolution_percentage = 100
scene.view_settings.view_transform = "Standard"
scene.render.image_settings.file_format = "OPEN_EXR"
scene.render.image_settings.color_depth = "32"

strip = in_blender.new_plane("Strip")  # [-1, 1]^2, placed over x, y in [0, 2] x [0, 0.25]
strip.scale, strip.location = (1.0, 0.125, 1.0), (1.0, 0.125, 0.0)
cam_data = bpy.data.cameras.new("Cam")
cam_data.type, cam_data.ortho_scale = "ORTHO", 2.0
cam = bpy.data.objects.new("Cam", cam_data)
cam.location = (1.0, 0.125, 5.0)
scene.collection.objects.link(cam)
scene.camera = cam


def render(kind, mode):
    mat = bpy.data.materials.new(f"{kind}_{mode}")
    mat.use_nodes = True
    nodes, links = mat.node_tree.nodes, mat.node_tree.links
    nodes.clear()
    out = nodes.new("ShaderNodeOutputMaterial")
    emit = nodes.new("ShaderNodeEmission")
    coords = nodes.new("ShaderNodeTexCoord")
    shift = nodes.new("ShaderNodeVectorMath")  # uvw x = object x + 1 in [0, 2]; z = 0.37
    shift.operation = "ADD"
    shift.inputs[1].default_value = (1.0, 0.0, 0.37)
    links.new(coords.outputs["Object"], shift.inputs[0])
    if mode == "tileable":
        t = nodes.new("ShaderNodeGroup")
        t.node_tree = tileable.group(kind)
    else:
        idname, settings = tileable.KINDS[kind]
        t = nodes.new(idname)
        for key, value in settings.items():
            t.inputs[key].default_value = value
    if mode == "frac":
        frac = nodes.new("ShaderNodeVectorMath")
        frac.operation = "FRACTION"
        links.new(shift.outputs["Vector"], frac.inputs[0])
        links.new(frac.outputs["Vector"], t.inputs["Vector"])
    else:
        links.new(shift.outputs["Vector"], t.inputs["Vector"])
    links.new(t.outputs["Color"], emit.inputs["Color"])
    links.new(emit.outputs["Emission"], out.inputs["Surface"])
    strip.data.materials.clear()
    strip.data.materials.append(mat)
    path = os.path.join(tmp, f"{kind}_{mode}.exr")
    scene.render.filepath = path
    bpy.ops.render.render(write_still=True)
    img = bpy.data.images.load(path)
    px = np.array(img.pixels[:], np.float32).reshape(H, W, 4)[:, :, :3]
    bpy.data.images.remove(img)
    return px


def seam(px):
    """The colour step across x = 1 (columns 31 | 32) over the mean step between columns."""
    step = np.abs(np.diff(px, axis=1)).mean(axis=(0, 2))
    return step[31] / np.delete(step, 31).mean()


cut_seams = []
for kind in tileable.KINDS:
    tiled, plain, cut = (render(kind, m) for m in ("tileable", "plain", "frac"))
    # Columns c and c + 32 are one uvw unit apart.
    diff_t = np.abs(tiled[:, :32] - tiled[:, 32:]).max()
    diff_p = np.abs(plain[:, :32] - plain[:, 32:]).max()
    print(f"{kind}: a unit apart the tileable differs by {diff_t:.2e}, the plain by "
          f"{diff_p:.2e}; seam at x = 1: tileable {seam(tiled):.2f}, frac {seam(cut):.2f} "
          f"times a step; std {tiled.std():.3f}")
    assert tiled.std() > 0.02  # a texture, not a flat colour
    assert diff_p > 0.05 and diff_t < 1e-3, (diff_p, diff_t)
    assert seam(tiled) < 2.0, seam(tiled)
    cut_seams.append(seam(cut))
# The wave's bands are steep everywhere, so a seam hides among its steps; the noise's does not.
assert max(cut_seams) > 3.0, cut_seams
print("TILEABLE OK")
