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
