"""Fluid texturing through the addon: SPH fills a box inside a domain; the bake becomes a
Volume object with the VDB grids and a textured surface mesh that follows the frame."""
import os
import time

import bpy
import numpy as np

import in_blender

in_blender.enable()
from hydrobake.blender.bridge import volumes  # noqa: E402

tmp = in_blender.args()[0]
bpy.ops.wm.save_as_mainfile(filepath=os.path.join(tmp, "dam.blend"))
scene = bpy.context.scene
import bmesh  # noqa: E402
domain = in_blender.new_plane("Domain")  # made a unit cube below
bm = bmesh.new()
bmesh.ops.create_cube(bm, size=1.0)
bm.to_mesh(domain.data)
bm.free()
domain.scale, domain.location = (1.0, 0.5, 0.5), (0.5, 0.25, 0.25)
fill = in_blender.new_plane("Water Column")
bm = bmesh.new()
bmesh.ops.create_cube(bm, size=1.0)
bm.to_mesh(fill.data)
bm.free()
fill.scale, fill.location = (0.25, 0.45, 0.4), (0.15, 0.25, 0.21)
s = domain.hydrobake_fluid
s.enabled, s.fill_object = True, fill
s.fluid.resolution = (16, 8, 8)
s.fluid.substeps = 8
s.fluid.textures = 3  # three: a blend of three columns is not a vector
s.use_scene_range, s.frame_start, s.frame_end = False, 1, 3
s.fluid.texture_scale[0] = 2.0
domain.display_type, domain.hide_render = "WIRE", True  # the artist's view: Free gives it back
# Texture 0 is the user's node group (a checker at uvw); texture 1 the built-in waves.
grp = bpy.data.node_groups.new("Checks", "ShaderNodeTree")
grp.inputs.new("NodeSocketVector", "UVW")
grp.outputs.new("NodeSocketColor", "Color")
gin, gout = grp.nodes.new("NodeGroupInput"), grp.nodes.new("NodeGroupOutput")
chk = grp.nodes.new("ShaderNodeTexChecker")
grp.links.new(gin.outputs["UVW"], chk.inputs["Vector"])
grp.links.new(chk.outputs["Color"], gout.inputs["Color"])
bad = bpy.data.node_groups.new("No Input", "ShaderNodeTree")
bad.outputs.new("NodeSocketColor", "Color")
with bpy.context.temp_override(object=domain):
    assert bpy.ops.hydrobake.fluid_sample(action="ADD") == {"FINISHED"}
    assert bpy.ops.hydrobake.fluid_sample(action="ADD") == {"FINISHED"}
    assert bpy.ops.hydrobake.fluid_sample(action="REMOVE") == {"FINISHED"}
assert len(s.samples) == 1
s.samples[0].group = bad
try:
    bpy.ops.hydrobake.bake(effect="fluid", object_name="Domain")
    raise AssertionError("baked with a group that has no vector input")
except RuntimeError as exc:
    assert "texture 0: node group 'No Input' needs a Vector input" in str(exc), exc
s.samples[0].group = grp
# Texture 1: a voxel solid texture, the core's tileable noise written by the operator.
with bpy.context.temp_override(object=domain):
    assert bpy.ops.hydrobake.fluid_sample(action="ADD") == {"FINISHED"}
    assert bpy.ops.hydrobake.fluid_noise_texture(index=1, size=16) == {"FINISHED"}
assert s.samples[1].voxel_file.startswith("//hydrobake_textures/")
assert os.path.isfile(bpy.path.abspath(s.samples[1].voxel_file))
assert bpy.ops.hydrobake.bake(effect="fluid", object_name="Domain") == {"FINISHED"}
vol = bpy.data.objects["HBK_Domain_volume"]
scene.frame_set(2)
grids = volumes.grid_names(vol)
assert {"density", "velocity", "uvw", "uvw_b", "uvw_unwrapped", "uvw_b_unwrapped",
        "uvw_weight", "blend_0", "blend_1", "blend_2"} <= set(grids), grids
# The Volume's shader reads the same grids: density for the fog, textures at the unwrapped uvw
# (Cycles interpolates without the wrap flags).
vmat = vol.data.materials[0]
vnodes = vmat.node_tree.nodes
pv = next(n for n in vnodes if n.type == "PRINCIPLED_VOLUME")
assert pv.inputs["Density"].is_linked and pv.inputs["Color"].is_linked
vattrs = {n.attribute_name for n in vnodes if n.type == "ATTRIBUTE"}
assert {"density", "uvw_unwrapped", "uvw_b_unwrapped", "uvw_weight", "blend_0",
        "blend_1"} <= vattrs, vattrs
assert not {"uvw", "uvw_b"} & vattrs, vattrs
assert "sample_1" not in vattrs  # a voxel texture has no volume form: a built-in stands in
# Texture 0 is the user's group (fields A and B); plain built-ins stand in for the others.
vgroups = [n.node_tree.name for n in vnodes if n.type == "GROUP"]
assert vgroups == [grp.name] * 2, vgroups
assert sum(n.type in ("TEX_WAVE", "TEX_VORONOI") for n in vnodes) == 4
surf = bpy.data.objects["HBK_Domain_surface"]
assert len(surf.data.polygons) > 0 and "uvw_a" in surf.data.attributes
assert "uvw_weight" in surf.data.attributes and "blend_1" in surf.data.attributes
# uvw per face corner, each triangle's corners within half a tile of each other (the short way
# across a wrap), and the field's gradient as the custom normals.
for name in ("uvw_a", "uvw_b"):
    at = surf.data.attributes[name]
    assert at.domain == "CORNER", at.domain
    c = np.empty(len(surf.data.loops) * 3, np.float32)
    at.data.foreach_get("vector", c)
    c = c.reshape(-1, 3, 3)
    assert np.abs(c - c[:, :1]).max() <= 0.5, np.abs(c - c[:, :1]).max()
assert surf.data.has_custom_normals
n2 = len(surf.data.vertices)
scene.frame_set(3)
assert len(surf.data.vertices) > 0
mat = surf.data.materials[0]
assert mat.name == "HBK_Domain_textured"
nodes = mat.node_tree.nodes

def upstream(node, seen=None):
    """The nodes a node reads from, itself included."""
    seen = set() if seen is None else seen
    if node.name not in seen:
        seen.add(node.name)
        for sock in node.inputs:
            for link in sock.links:
                upstream(link.from_node, seen)
    return seen


outputs = {n.target: n for n in nodes if n.type == "OUTPUT_MATERIAL"}
assert set(outputs) == {"CYCLES", "EEVEE"}
cycles = [nodes[n] for n in upstream(outputs["CYCLES"])]
eevee = [nodes[n] for n in upstream(outputs["EEVEE"])]
groups = [n for n in cycles if n.type == "GROUP" and n.node_tree == grp]  # fields A and B
assert len(groups) == 2
builtin = [n.node_tree.name for n in cycles if n.type == "GROUP" and n.node_tree != grp]
assert builtin == ["HBK Tileable Voronoi"] * 2, builtin  # texture 2; 1 is the voxel texture
# The viewport's EEVEE preview: the plain built-ins (the tileable ones took minutes to
# compile without a GPU), the user's group as it is, the same weights.
assert [n.node_tree.name for n in eevee if n.type == "GROUP"] == [grp.name] * 2
assert sum(n.type == "TEX_VORONOI" for n in eevee) == 2
assert {"blend_0", "blend_1", "blend_2"} <= {n.attribute_name for n in eevee
                                             if n.type == "ATTRIBUTE"}
for n in groups:  # fed uvw_a or uvw_b times texture 0's scale
    sc = n.inputs["UVW"].links[0].from_node
    assert sc.operation == "SCALE" and sc.inputs["Scale"].default_value == 2.0
    assert sc.inputs[0].links[0].from_node.attribute_name in ("uvw_a", "uvw_b")
assert not any(n.type == "TEX_WAVE" for n in nodes)
blends = {n.attribute_name for n in nodes if n.type == "ATTRIBUTE"}
assert {"blend_0", "blend_1", "blend_2", "uvw_weight", "sample_1"} <= blends
assert "blend_3" not in blends
# Every blend weight is its own attribute, and they sum to one at every vertex.
ws = []
for k in range(3):
    a = np.empty(len(surf.data.vertices), np.float32)
    surf.data.attributes[f"blend_{k}"].data.foreach_get("value", a)
    ws.append(a)
np.testing.assert_allclose(np.sum(ws, axis=0), 1.0, atol=1e-5)
col = surf.data.attributes["sample_1"]
vals = np.empty(len(surf.data.vertices) * 3, np.float32)
col.data.foreach_get("vector", vals)
assert 0.0 <= vals.min() and vals.max() <= 1.0 and vals.std() > 0.01  # noise, per vertex
bsdf = next(n for n in nodes if n.type == "BSDF_PRINCIPLED")
assert bsdf.inputs["Base Color"].is_linked
# EEVEE renders it (the viewport plays it back), in seconds.
scene.render.engine = "BLENDER_EEVEE"
scene.eevee.taa_render_samples = 1
scene.render.resolution_x, scene.render.resolution_y = 64, 36
scene.render.filepath = os.path.join(tmp, "eevee.png")
t0 = time.monotonic()
bpy.ops.render.render(write_still=True)
assert os.path.isfile(scene.render.filepath)
print(f"EEVEE render {time.monotonic() - t0:.1f} s")
assert bpy.ops.hydrobake.free_bake(effect="fluid", object_name="Domain") == {"FINISHED"}
assert "HBK_Domain_volume" not in bpy.data.objects and "HBK_Domain_surface" not in bpy.data.objects
assert (domain.display_type, domain.hide_render) == ("WIRE", True), domain.display_type
# The textured materials are kept unused for a re-bake (with the artist's edits).
assert all(m.users == 0 for m in bpy.data.materials if m.name.startswith("HBK_Domain"))
print("FLUID BLENDER OK", n2)


class FakeLayout:
    """Stands in for a panel's layout: every property drawn must exist, every operator too."""

    def __init__(self, log):
        self.log = log

    def __getattr__(self, name):  # column, row, box, split...
        return lambda *a, **k: self if name != "operator" else self._op(*a)

    def _op(self, idname, *a):
        mod, op = idname.split(".")
        assert hasattr(getattr(bpy.ops, mod), op), idname
        self.log.append(idname)
        return type("Props", (), {})()

    def prop(self, data, name, **k):
        assert hasattr(data, name), name
        self.log.append(name)

    def label(self, **k):
        pass


from hydrobake.blender import effects  # noqa: E402
log = []
s.samples.add()
effects.BLENDER_EFFECTS["fluid"].draw_settings(FakeLayout(log), s)
assert {"liquid_domain", "group", "voxel_file", "hydrobake.fluid_noise_texture",
        "hydrobake.fluid_sample"} <= set(log), log
print("FLUID PANEL OK")
