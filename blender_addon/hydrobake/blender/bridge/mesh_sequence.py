"""Baked mesh sequences (``<stream>_####.npz`` with positions, triangles and per-vertex
attributes) as a mesh object that follows the frame."""
import os

import bpy
import numpy as np

PROP = "hydrobake_mesh_sequence"  # on the object: "folder|stream"


def load(obj, frame):
    """Rebuilds the object's mesh from the file baked for ``frame`` (empty if none)."""
    folder, stream = obj[PROP].split("|")
    path = os.path.join(folder, f"{stream}_{frame:04d}.npz")
    mesh = obj.data
    mesh.clear_geometry()
    if not os.path.isfile(path):
        return
    with np.load(path) as d:
        pos, tris = d["positions"], d["triangles"]
        attrs = {k: d[k] for k in d.files if k not in ("positions", "triangles", "normals")}
    mesh.vertices.add(len(pos))
    mesh.vertices.foreach_set("co", np.ascontiguousarray(pos, np.float32).ravel())
    n = len(tris)
    mesh.loops.add(3 * n)
    mesh.loops.foreach_set("vertex_index", np.ascontiguousarray(tris, np.int32).ravel())
    mesh.polygons.add(n)
    mesh.polygons.foreach_set("loop_start", np.arange(0, 3 * n, 3, dtype=np.int32))
    mesh.polygons.foreach_set("loop_total", np.full(n, 3, np.int32))
    mesh.polygons.foreach_set("use_smooth", np.ones(n, bool))
    # uvw_a, uvw_b: vectors; uvw_weight: one value; blend, features: one attribute per column
    for name, arr in attrs.items():
        arr = np.ascontiguousarray(arr, np.float32)
        if arr.ndim == 2 and arr.shape[1] == 3:
            a = mesh.attributes.new(name, "FLOAT_VECTOR", "POINT")
            a.data.foreach_set("vector", arr.ravel())
        elif arr.ndim == 1:
            a = mesh.attributes.new(name, "FLOAT", "POINT")
            a.data.foreach_set("value", arr)
        else:
            cols = arr.reshape(len(pos), -1)
            for k in range(cols.shape[1]):
                a = mesh.attributes.new(f"{name}_{k}", "FLOAT", "POINT")
                a.data.foreach_set("value", np.ascontiguousarray(cols[:, k]))
    mesh.update()


@bpy.app.handlers.persistent
def on_frame(scene, *_args):
    for obj in bpy.data.objects:
        if PROP in obj and obj.type == "MESH":
            own = obj.users_scene[0] if obj.users_scene else scene
            load(obj, own.frame_current)


def attach(name, folder, stream, frame, collection=None, material=None):
    obj = bpy.data.objects.get(name)
    if obj is None:
        obj = bpy.data.objects.new(name, bpy.data.meshes.new(name))
        (collection or bpy.context.scene.collection).objects.link(obj)
    obj[PROP] = f"{folder}|{stream}"
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
