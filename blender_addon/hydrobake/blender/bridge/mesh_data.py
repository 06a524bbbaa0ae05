"""Evaluated meshes as numpy arrays: triangles, per-corner UVs, material slots."""
import numpy as np

from .depsgraph import evaluated as evaluated_depsgraph, evaluated_object


def triangles(obj, depsgraph=None, world=True, uv_name=None, role=None):
    """(positions (V, 3), triangles (T, 3), uvs (T, 3, 2) or None, material_index (T,)) of
    the evaluated object; positions in world space unless ``world`` is False. ValueError
    naming the object (as the setting ``role``, if given) where it is not evaluated."""
    depsgraph = depsgraph or evaluated_depsgraph()
    ev = evaluated_object(obj, depsgraph, role)
    mesh = ev.to_mesh()
    try:
        mesh.calc_loop_triangles()
        nv, nt = len(mesh.vertices), len(mesh.loop_triangles)
        pos = np.empty(nv * 3, np.float32)
        mesh.vertices.foreach_get("co", pos)
        pos = pos.reshape(nv, 3)
        if world:
            m = np.array(obj.matrix_world, np.float64)
            pos = (pos @ m[:3, :3].T + m[:3, 3]).astype(np.float32)
        tris = np.empty(nt * 3, np.int32)
        mesh.loop_triangles.foreach_get("vertices", tris)
        loops = np.empty(nt * 3, np.int32)
        mesh.loop_triangles.foreach_get("loops", loops)
        mi = np.empty(nt, np.int32)
        mesh.loop_triangles.foreach_get("material_index", mi)
        uvs = None
        layer = (mesh.uv_layers.get(uv_name) if uv_name else mesh.uv_layers.active)
        if layer is not None:
            per_loop = np.empty(len(mesh.loops) * 2, np.float32)
            layer.data.foreach_get("uv", per_loop)
            uvs = per_loop.reshape(-1, 2)[loops].reshape(nt, 3, 2)
        return pos, tris.reshape(nt, 3), uvs, mi
    finally:
        ev.to_mesh_clear()


def shape(obj, depsgraph, role=None):
    """(positions (V, 3) in the object's own space, faces) of the evaluated object: faces are
    the loops' vertex indices, equal on two frames whose faces are the same. (Its triangles
    may differ then: a quad bent past its other diagonal is split along that one.)"""
    ev = evaluated_object(obj, depsgraph, role)
    mesh = ev.to_mesh()
    try:
        pos = np.empty(len(mesh.vertices) * 3, np.float32)
        mesh.vertices.foreach_get("co", pos)
        faces = np.empty(len(mesh.loops), np.int32)
        mesh.loops.foreach_get("vertex_index", faces)
        return pos.reshape(-1, 3), faces
    finally:
        ev.to_mesh_clear()
