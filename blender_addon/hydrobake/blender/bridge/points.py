"""Baked point sequences (falling flakes) as a points object that follows the frame, with a
Geometry Nodes modifier instancing a small sphere on every point."""
import bpy

from . import frame_meshes


def _instancer(radius):
    name = f"HBK Flake Instancer {radius:.4f}"
    ng = bpy.data.node_groups.get(name)
    if ng is not None:
        return ng
    ng = bpy.data.node_groups.new(name, "GeometryNodeTree")
    ng.inputs.new("NodeSocketGeometry", "Geometry")
    ng.outputs.new("NodeSocketGeometry", "Geometry")
    nodes, links = ng.nodes, ng.links
    gin, gout = nodes.new("NodeGroupInput"), nodes.new("NodeGroupOutput")
    ico = nodes.new("GeometryNodeMeshIcoSphere")
    ico.inputs["Radius"].default_value = radius
    ico.inputs["Subdivisions"].default_value = 1
    inst = nodes.new("GeometryNodeInstanceOnPoints")
    links.new(gin.outputs["Geometry"], inst.inputs["Points"])
    links.new(ico.outputs["Mesh"], inst.inputs["Instance"])
    links.new(inst.outputs["Instances"], gout.inputs["Geometry"])
    return ng


def attach(name, folder, stream, radius, collection=None, material=None):
    obj = frame_meshes.attach(name, "points", folder, stream, collection, material)
    mod = obj.modifiers.get("HBK Instances") or obj.modifiers.new("HBK Instances", "NODES")
    mod.node_group = _instancer(radius)
    return obj


def detach(name):
    """Removes the points object, and its instancer and material once nothing else uses them
    (shared by every flake object of the same size)."""
    obj = bpy.data.objects.get(name)
    if obj is None:
        return
    mod = obj.modifiers.get("HBK Instances")
    group = mod.node_group if mod is not None else None
    mats = [m for m in obj.data.materials if m is not None]
    frame_meshes.detach(name)
    if group is not None and group.users == 0:
        bpy.data.node_groups.remove(group)
    for mat in mats:
        if mat.users == 0 and mat.name.startswith("HBK "):
            bpy.data.materials.remove(mat)
