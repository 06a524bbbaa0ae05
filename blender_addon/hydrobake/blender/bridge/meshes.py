"""Meshes as height fields (ray casts against evaluated objects in world space), their boxes in
the world, and which object holds a metaball's surface."""
import numpy as np
from mathutils import Matrix, Vector
from mathutils.bvhtree import BVHTree

from .depsgraph import evaluated as evaluated_depsgraph, evaluated_object


def _name_number(name):
    """Blender's split of an object's name into base and number: "Mball.002" is ("Mball", 2),
    "Mball" ("Mball", 0)."""
    head, dot, tail = name.rpartition(".")
    return (head, int(tail)) if dot and head and tail.isdigit() else (name, 0)


def metaball_family(obj):
    """The metaballs Blender melts into one surface with ``obj``: those in its scenes whose
    names share its base ("Mball", "Mball.001"), the lowest number (the basis) first. The
    basis alone evaluates to the mesh, which holds them all in its own axes; the others
    evaluate to no face, and their boxes are empty."""
    base = _name_number(obj.name)[0]
    found = {o for s in obj.users_scene for o in s.objects
             if o.type == "META" and _name_number(o.name)[0] == base}
    found.add(obj)
    return sorted(found, key=lambda o: (_name_number(o.name)[1], o.name))


def shape_holder(obj):
    """The object whose evaluated mesh is ``obj``'s surface: a metaball's family's basis (the
    family's one surface), else the object itself."""
    return metaball_family(obj)[0] if obj.type == "META" else obj


def world_bounds(obj):
    """(min xyz, max xyz) of the object's bounding box in world space."""
    pts = np.array([tuple(obj.matrix_world @ Vector(c)) for c in obj.bound_box])
    return pts.min(axis=0), pts.max(axis=0)


def own_axes(matrix):
    """(rotation (3, 3): its columns the object's axes in the world, scale (3,): signed, a
    mirrored axis negative) of a world matrix, or None where it shears or flattens (its axes
    would not be a box's)."""
    m = np.array(matrix, np.float64)[:3, :3]
    scale = np.linalg.norm(m, axis=0)
    if not (scale > 0.0).all():
        return None
    r = m / scale
    if np.abs(r.T @ r - np.eye(3)).max() > 1e-4:
        return None
    if np.linalg.det(r) < 0.0:  # mirrored: a proper turn and a negative scale along x
        r[:, 0], scale[0] = -r[:, 0], -scale[0]
    return r, scale


def quaternion(r):
    """The unit quaternion (w, x, y, z) of a rotation matrix."""
    q = Matrix(np.asarray(r).tolist()).to_quaternion().normalized()
    return float(q.w), float(q.x), float(q.y), float(q.z)


def turned_bounds(obj):
    """(centre, half-sizes, rotation (w, x, y, z)) in the world of the object's own bounding
    box turned with it: bound_box (in its own axes) scaled and turned by its world matrix.
    None where that matrix does not turn (world_bounds is then the same box) or shears (the
    box would not be one)."""
    axes = own_axes(obj.matrix_world)
    if axes is None or np.abs(axes[0] - np.eye(3)).max() <= 1e-6:
        return None
    r, scale = axes
    m = np.array(obj.matrix_world, np.float64)
    corners = np.array([tuple(c) for c in obj.bound_box], np.float64)
    lo, hi = corners.min(axis=0), corners.max(axis=0)
    centre = m[:3, :3] @ ((lo + hi) / 2) + m[:3, 3]
    return (tuple(map(float, centre)), tuple(map(float, (hi - lo) / 2 * np.abs(scale))),
            quaternion(r))


def _world_tree(obj, depsgraph, role):
    ev = evaluated_object(obj, depsgraph, role)
    try:
        mesh = ev.to_mesh()
    except RuntimeError:  # a camera, lamp or empty: nothing to cast rays at
        who = f"{role}: {obj.name!r}" if role else obj.name
        raise ValueError(f"{who} has no surface (a {obj.type.lower()}); give a mesh") from None
    try:
        mesh.transform(obj.matrix_world)
        verts = [tuple(v.co) for v in mesh.vertices]
        polys = [tuple(p.vertices) for p in mesh.polygons]
    finally:
        ev.to_mesh_clear()
    return BVHTree.FromPolygons(verts, polys, epsilon=0.0)


def sample_heights(obj, origin, cell_size, shape, direction="DOWN", depsgraph=None,
                   miss=np.nan, angle=0.0, role=None):
    """Heights (world z) where vertical rays through cell centres hit ``obj``.

    Cell (i, j) has its centre at origin + R(angle) ((i + 0.5) cell, (j + 0.5) cell), R a turn
    about z (a grid turned with its object). DOWN: the topmost surface (ground); UP: the
    lowest surface (an object's underside). Rows are j. ``role`` names the setting ``obj``
    is, in the error for an object that is not evaluated."""
    depsgraph = depsgraph or evaluated_depsgraph()
    obj = shape_holder(obj)
    tree = _world_tree(obj, depsgraph, role)
    lo, hi = world_bounds(obj)
    h, w = shape
    out = np.full(shape, miss, np.float32)
    c, s = float(np.cos(angle)), float(np.sin(angle))
    # Only cells inside the object's footprint can hit it: its box's corners in the grid.
    xs, ys = np.array([lo[0], hi[0]]) - origin[0], np.array([lo[1], hi[1]]) - origin[1]
    us = [c * x + s * y for x in xs for y in ys]
    vs = [-s * x + c * y for x in xs for y in ys]
    i0 = max(int(np.floor(min(us) / cell_size - 0.5)), 0)
    i1 = min(int(np.ceil(max(us) / cell_size + 0.5)), w - 1)
    j0 = max(int(np.floor(min(vs) / cell_size - 0.5)), 0)
    j1 = min(int(np.ceil(max(vs) / cell_size + 0.5)), h - 1)
    if i1 < i0 or j1 < j0:
        return out
    down = direction == "DOWN"
    z0 = hi[2] + 1.0 if down else lo[2] - 1.0
    ray = Vector((0.0, 0.0, -1.0 if down else 1.0))
    dist = (hi[2] - lo[2]) + 2.0
    for j in range(j0, j1 + 1):
        v = (j + 0.5) * cell_size
        for i in range(i0, i1 + 1):
            u = (i + 0.5) * cell_size
            start = Vector((origin[0] + c * u - s * v, origin[1] + s * u + c * v, z0))
            hit = tree.ray_cast(start, ray, dist)
            if hit[0] is not None:
                out[j, i] = hit[0].z
    return out


def world_vertices(obj):
    """The object's own mesh vertices (before modifiers) in world space, (n, 3) float64."""
    co = np.empty(len(obj.data.vertices) * 3, np.float64)
    obj.data.vertices.foreach_get("co", co)
    m = np.array(obj.matrix_world, np.float64)
    return co.reshape(-1, 3) @ m[:3, :3].T + m[:3, 3]


def data_world_bounds(obj):
    """(min xyz, max xyz) of the object's own mesh (before modifiers) in world space: a fluid
    domain's box even while it shows its liquid."""
    if not obj.data.vertices:
        raise ValueError(f"{obj.name}: its mesh has no vertices, so no box")
    pts = world_vertices(obj)
    return pts.min(axis=0), pts.max(axis=0)


def z_crossings(obj, xs, ys, z_lo, z_hi, depsgraph=None, role=None):
    """Where the evaluated surface of ``obj`` crosses each vertical line (x, y) for x in xs, y
    in ys, between z_lo and z_hi: (heights, counts (len(ys), len(xs))), heights line after line
    (y rows, then x), ascending within a line."""
    depsgraph = depsgraph or evaluated_depsgraph()
    tree = _world_tree(shape_holder(obj), depsgraph, role)
    up = Vector((0.0, 0.0, 1.0))
    eps = 1e-6 * max(z_hi - z_lo, 1e-6)
    counts = np.zeros((len(ys), len(xs)), np.int32)
    heights = []
    for j, y in enumerate(ys):
        for i, x in enumerate(xs):
            z = z_lo - eps
            while True:
                hit = tree.ray_cast(Vector((float(x), float(y), z)), up, z_hi + eps - z)
                if hit[0] is None:
                    break
                heights.append(hit[0].z)
                counts[j, i] += 1
                z = hit[0].z + eps
    return np.array(heights, np.float32), counts
