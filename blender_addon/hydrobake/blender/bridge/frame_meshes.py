"""Mesh objects rebuilt on every frame change from a baked ``<tag><stream>_####.npz`` sequence:
points (falling flakes) and surfaces (the fluid's mesh with its attributes)."""
import os

import bpy
import numpy as np

from ...core.bake.cache import stem_in
from .. import paths

PROP = "hydrobake_sequence"  # on the object: "kind|folder|stem" (the files' <tag><stream>)
PROP_BASE = "hydrobake_sequence_base"  # the folder a relative one is relative to (paths)
FRAME = "hydrobake_frame"  # on the object: the frame its mesh holds


def _points(mesh, data):
    pos = np.ascontiguousarray(data["positions"], np.float32)
    mesh.vertices.add(len(pos))
    mesh.vertices.foreach_set("co", pos.ravel())


def _surface(mesh, data):
    pos, tris = data["positions"], data["triangles"]
    mesh.vertices.add(len(pos))
    mesh.vertices.foreach_set("co", np.ascontiguousarray(pos, np.float32).ravel())
    n = len(tris)
    mesh.loops.add(3 * n)
    mesh.loops.foreach_set("vertex_index", np.ascontiguousarray(tris, np.int32).ravel())
    mesh.polygons.add(n)
    mesh.polygons.foreach_set("loop_start", np.arange(0, 3 * n, 3, dtype=np.int32))
    mesh.polygons.foreach_set("loop_total", np.full(n, 3, np.int32))
    mesh.polygons.foreach_set("use_smooth", np.ones(n, bool))
    if "normals" in data.files and len(pos):
        # The field's gradient, not the faces' mean: marching-cubes triangles are uneven, and
        # averaged face normals would shade them as creases.
        mesh.update(calc_edges=True)  # custom normals walk the edges around each vertex
        if hasattr(mesh, "use_auto_smooth"):  # Blender < 4.1 reads custom normals only so
            mesh.use_auto_smooth = True
        mesh.normals_split_custom_set_from_vertices(
            np.ascontiguousarray(data["normals"], np.float32).reshape(-1, 3))
    # uvw_a, uvw_b, sample_k: vectors; uvw_weight: one value; blend, features: an attribute
    # per column (by name: three textures make a blend of three columns, still not a vector).
    for name in data.files:
        if name in ("positions", "triangles", "normals"):
            continue
        arr = np.ascontiguousarray(data[name], np.float32)
        vector = name in ("uvw_a", "uvw_b") or name.startswith("sample_")
        if name in ("uvw_a", "uvw_b") and arr.ndim == 2 and n:
            # uvw wraps at 1 -> 0 (a tile edge). Per vertex, a triangle across the wrap would
            # interpolate the long way and squeeze a whole tile into itself (zigzag stripes);
            # per face corner, each triangle's corners are taken within half a tile of its
            # first, so it interpolates the short way, as the volume's wrap flags do.
            c = arr[np.asarray(tris, np.int64).reshape(-1, 3)]
            c -= np.round(c - c[:, :1, :])
            mesh.attributes.new(name, "FLOAT_VECTOR", "CORNER").data.foreach_set(
                "vector", np.ascontiguousarray(c, np.float32).ravel())
        elif vector and arr.ndim == 2 and arr.shape[1] == 3:
            mesh.attributes.new(name, "FLOAT_VECTOR", "POINT").data.foreach_set(
                "vector", arr.ravel())
        elif arr.ndim == 1:
            mesh.attributes.new(name, "FLOAT", "POINT").data.foreach_set("value", arr)
        else:
            cols = arr if arr.ndim == 2 else arr.reshape(len(pos), -1)  # (0, k) stays so
            for k in range(cols.shape[1]):
                mesh.attributes.new(f"{name}_{k}", "FLOAT", "POINT").data.foreach_set(
                    "value", np.ascontiguousarray(cols[:, k]))


LOADERS = {"points": _points, "surface": _surface}


def load(obj, frame):
    """Rebuilds the object's mesh from the file baked for ``frame`` (empty if there is none).
    In Edit Mode the mesh is left as it is (Blender allows no new geometry there, and the
    edits would be written back over it): the frame it holds stays in FRAME. So is a mesh
    linked from a library, as the library saved it: Blender 3.4 lets Python rebuild linked
    data unchecked, and crashed at times doing so (saved_elsewhere.py)."""
    if obj.mode == "EDIT" or obj.data.library is not None:
        return
    kind, _folder, stream = obj[PROP].split("|", 2)
    path = os.path.join(folder_of(obj), f"{stream}_{frame:04d}.npz")
    mesh = obj.data
    mesh.clear_geometry()
    obj[FRAME] = frame
    if os.path.isfile(path):
        with np.load(path) as data:
            LOADERS[kind](mesh, data)
    mesh.update()


def folder_of(obj):
    """The absolute folder of the sequence ``obj`` shows, or None if it shows none."""
    parts = str(obj.get(PROP, "")).split("|", 2)
    return paths.resolve(parts[1], obj.get(PROP_BASE), obj.library) if len(parts) == 3 \
        else None


def _frame_of(obj, fallback):
    """The frame of the scene the object is in (a handler may be called for another scene
    than the one that changed)."""
    return (obj.users_scene[0] if obj.users_scene else fallback).frame_current


@bpy.app.handlers.persistent
def on_frame(scene, *_args):
    for obj in bpy.data.objects:
        if PROP in obj and obj.type == "MESH":
            frame = _frame_of(obj, scene)
            try:
                load(obj, frame)
            except Exception as exc:  # noqa: BLE001
                # A damaged file must not stop the other sequences from following the frame.
                print(f"Hydrobake: {obj.name}: frame {frame}: damaged file ({exc}); Resume "
                      "the bake to bake it again")


def ensure_handler():
    if on_frame not in bpy.app.handlers.frame_change_post:
        bpy.app.handlers.frame_change_post.append(on_frame)


def attach(name, kind, folder, stream, collection=None, material=None):
    """The object ``name`` (made or reused, linked to ``collection``) showing the bake's
    ``folder``/``stream`` at every frame, starting with its scene's current one."""
    if kind not in LOADERS:
        raise ValueError(f"kind = {kind!r}: must be one of {', '.join(LOADERS)}")
    obj = bpy.data.objects.get(name)
    if obj is None:
        obj = bpy.data.objects.new(name, bpy.data.meshes.new(name))
        (collection or bpy.context.scene.collection).objects.link(obj)
    paths.record(obj, PROP, f"{kind}|{folder}|{stem_in(folder, stream)}", PROP_BASE, folder)
    if material is not None and not obj.data.materials:
        obj.data.materials.append(material)
    load(obj, _frame_of(obj, bpy.context.scene))
    ensure_handler()
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
