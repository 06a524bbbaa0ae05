"""Baked point sequences (``<stream>_####.npz`` with "positions") as a points-only mesh object
that follows the frame, with a Geometry Nodes modifier instancing a small sphere on each."""
import os

import bpy
import numpy as np

PROP = "hydrobake_points"  # on the object: "folder|stream", what to load each frame


def load(obj, frame):
    """Replaces the object's vertices with the positions baked for ``frame`` (if any)."""
    folder, stream = obj[PROP].split("|")
    path = os.path.join(folder, f"{stream}_{frame:04d}.npz")
    mesh = obj.data
    if not os.path.isfile(path):
        mesh.clear_geometry()
        return
    with np.load(path) as data:
        pos = np.ascontiguousarray(data["positions"], np.float32)
    mesh.clear_geometry()
    mesh.vertices.add(len(pos))
    mesh.vertices.foreach_set("co", pos.ravel())
    mesh.update()


@bpy.app.handlers.persistent
def on_frame(scene, *_args):
    # Each points object follows the frame of the scene it is in (a handler may be called
    # for another scene than the one that changed).
    for obj in bpy.data.objects:
        if PROP in obj and obj.type == "MESH":
            own = obj.users_scene[0] if obj.users_scene else scene
            load(obj, own.frame_current)


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


def attach(name, folder, stream, radius, frame, collection=None, material=None):
    """The points object ``name`` (made or reused) reading ``folder``/``stream``."""
    obj = bpy.data.objects.get(name)
    if obj is None:
        obj = bpy.data.objects.new(name, bpy.data.meshes.new(name))
        (collection or bpy.context.scene.collection).objects.link(obj)
    obj[PROP] = f"{folder}|{stream}"
    mod = obj.modifiers.get("HBK Instances") or obj.modifiers.new("HBK Instances", "NODES")
    mod.node_group = _instancer(radius)
    if material is not None and not obj.data.materials:
        obj.data.materials.append(material)
    load(obj, frame)
    if on_frame not in bpy.app.handlers.frame_change_post:
        bpy.app.handlers.frame_change_post.append(on_frame)
    return obj


def detach(name):
    obj = bpy.data.objects.get(name)
    if obj is not None:
        mesh = obj.data
        bpy.data.objects.remove(obj)
        if mesh.users == 0:
            bpy.data.meshes.remove(mesh)


def unregister():
    if on_frame in bpy.app.handlers.frame_change_post:
        bpy.app.handlers.frame_change_post.remove(on_frame)
