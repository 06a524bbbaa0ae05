"""The caustics effect through the real addon on examples.blend: bake a short range, check the
files and the wiring into the floor and water materials, render, then free and check the
materials are as they were."""
import json
import os

import bmesh
import bpy

import in_blender

in_blender.enable()
tmp = in_blender.args()[0]
bpy.ops.wm.save_as_mainfile(filepath=os.path.join(tmp, "pool.blend"))
scene = bpy.data.scenes["Caustics"]
water, floor = bpy.data.objects["Water"], bpy.data.objects["Pool Floor"]
s = water.hydrobake_caustics
before = [m.name if m else None for m in water.data.materials]  # as Free must leave them
assert s.enabled and s.ground_object == floor
s.use_scene_range = False
s.frame_start, s.frame_end = 1, 3
s.water.width = 64
s.map_resolution = 256
s.displace_surface = True
s.projector = True
s.preview_camera = scene.camera
s.ground_texture = bpy.data.images.new("tiles", 64, 64)
floor_tree = floor.data.materials[0].node_tree
bsdf = next(n for n in floor_tree.nodes if n.type == "BSDF_PRINCIPLED")
orig_from = bsdf.inputs["Base Color"].links[0].from_node.name

with bpy.context.temp_override(scene=scene):
    assert bpy.ops.hydrobake.bake(effect="caustics", object_name="Water") == {"FINISHED"}
folder = s.bake_folder
m = json.load(open(os.path.join(folder, "manifest.json")))
assert m["complete"] and sorted(map(int, m["frames"])) == [1, 2, 3]
assert m["params"]["water"]["width"] == 64 and m["params"]["water"]["height"] == 64
names = sorted(os.listdir(folder))
assert names == sorted(["manifest.json", "checkpoint_0001.bin", "checkpoint_0003.bin"] +
                      [f"{m['file_tag']}{st}_{i:04d}.exr" for i in (1, 2, 3)
                       for st in ("caustics", "surface", "height", "water", "view")]), names
assert bpy.data.images["HBK_Water_view"].source == "SEQUENCE"  # the paper's own rendering
assert bpy.data.images["HBK_Water_view"].use_fake_user  # no node shows it: kept when saved

# Wired: floor base colour = original texture x caustic sequence; water has the normal map.
link = bsdf.inputs["Base Color"].links[0]
assert link.from_node.get("hydrobake") == "caustics.multiply"
mix = link.from_node
assert mix.inputs["Color1"].links[0].from_node.name == orig_from
tex = mix.inputs["Color2"].links[0].from_node
assert tex.image.source == "SEQUENCE"
# Clipped at the water's edge, where the floor keeps its own colour (alpha 0: no multiply);
# the colour itself read past the edge, so the edge texel is not blended with black.
edge = mix.inputs["Fac"].links[0].from_node
assert edge.extension == "CLIP" and mix.inputs["Fac"].links[0].from_socket.name == "Alpha"
assert tex.extension == "EXTEND" and edge.image == tex.image
wtree = water.data.materials[0].node_tree
wbsdf = next(n for n in wtree.nodes if n.type == "BSDF_PRINCIPLED")
turn = wbsdf.inputs["Normal"].links[0].from_node
assert turn.get("hydrobake") == "caustics.normal_turn" and turn.inputs["Angle"].default_value == 0
assert turn.inputs["Vector"].links[0].from_node.get("hydrobake") == "caustics.normal"
assert not water.visible_shadow

# The surface moves: Displace by the baked heights over a UV map spanning the grid.
assert water.modifiers["HBK Displace"].texture.image.source == "SEQUENCE"
scene.frame_set(3)
dg = bpy.context.evaluated_depsgraph_get()
zs = [v.co.z for v in water.evaluated_get(dg).to_mesh().vertices]
assert len(zs) > 1000 and max(zs) - min(zs) > 1e-4, (len(zs), max(zs) - min(zs))

def faces_per_cell():
    """The displaced water's faces over the grid's cells (about one, at most four)."""
    dg = bpy.context.evaluated_depsgraph_get()
    grid = m["params"]["water"]  # the plane's cells (height follows its aspect)
    return len(water.evaluated_get(dg).data.polygons) / (grid["width"] * grid["height"])


assert 1 <= faces_per_cell() < 4, faces_per_cell()
water.evaluated_get(dg).to_mesh_clear()

# The projector: a spot light whose emission is the caustic sequence, aimed at the pool.
proj = bpy.data.objects["HBK_Water_projector"]
assert proj.type == "LIGHT" and proj.data.type == "SPOT"
ptex = next(n for n in proj.data.node_tree.nodes if n.type == "TEX_IMAGE")
assert ptex.image.source == "SEQUENCE"

# A small render: the caustic texture is found (no magenta 'missing image').
scene.render.resolution_x, scene.render.resolution_y = 64, 36
scene.render.resolution_percentage = 100
scene.cycles.samples = 2
# Also before the bake's first frame and after its last: they hold the first and the last.
for frame in (2, 0, 5):
    scene.frame_set(frame)
    scene.render.filepath = os.path.join(tmp, f"pool_{frame}.png")
    bpy.ops.render.render(write_still=True, scene=scene.name)
    img = bpy.data.images.load(scene.render.filepath)
    px = list(img.pixels)
    magenta = sum(1 for i in range(0, len(px), 4)
                  if px[i] > 0.9 and px[i + 1] < 0.1 and px[i + 2] > 0.9)
    assert magenta == 0, (frame, magenta)

# Free: files gone, floor link restored, water casts shadows again.
assert bpy.ops.hydrobake.free_bake(effect="caustics", object_name="Water") == {"FINISHED"}
assert not os.path.exists(folder)
assert bsdf.inputs["Base Color"].links[0].from_node.name == orig_from
assert not any(n.get("hydrobake") for n in floor_tree.nodes)
after = [m.name if m else None for m in water.data.materials]
assert after == before, (before, after)  # a material made for the bake is gone with it
assert all(m is None or not any(n.get("hydrobake") for n in m.node_tree.nodes)
           for m in water.data.materials)
assert water.visible_shadow and not s.is_baked
assert "HBK Displace" not in water.modifiers and "HBK_Water_grid" not in bpy.data.objects
assert "HBK_Water_projector" not in bpy.data.objects
assert "HBK_Water_view" not in bpy.data.images
assert "HBK_Water_height" not in bpy.data.textures  # the Displace's texture
# A dense water mesh is subdivided less: still about a face per cell, not 4^6 per face.
bm = bmesh.new()
bm.from_mesh(water.data)
bmesh.ops.subdivide_edges(bm, edges=bm.edges[:], cuts=15, use_grid_fill=True)
bm.to_mesh(water.data)
bm.free()
assert len(water.data.polygons) >= 256
with bpy.context.temp_override(scene=scene):
    assert bpy.ops.hydrobake.bake(effect="caustics", object_name="Water") == {"FINISHED"}
assert 1 <= faces_per_cell() < 4, faces_per_cell()
print("CAUSTICS BLENDER OK")
