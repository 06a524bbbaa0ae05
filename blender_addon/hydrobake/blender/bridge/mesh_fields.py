"""Meshes as the fluid's obstacles: a signed distance field of the mesh in its own axes (the
core's mesh obstacle), placed at each frame by the object's world matrix."""
import numpy as np
from mathutils.bvhtree import BVHTree

from .meshes import own_axes, quaternion

MAX_DIM = 128  # HBK_FLUID_FIELD_MAX_DIM
SIDE = 64  # points along a field's longest side, unless the particles need finer


class MeshShape:
    """A mesh's distance field, made once: ``field`` (nz, ny, nx) float32, m, negative inside
    (``signed``), or unsigned where the mesh has no clear inside (``signed`` False: open, or
    its faces' normals disagree), over a box of ``centre`` and ``half_sizes`` in the object's
    unscaled own coordinates."""

    def __init__(self, centre, half_sizes, field, signed):
        self.centre, self.half_sizes, self.field = centre, half_sizes, field
        self.signed = signed
        self.sheet = None  # (sheet_shape) the shell's half-thickness, m
        self.flat = None  # (sheet_shape) a flat sheet's face normal in its scaled own axes

    def placed(self, matrix, first):
        """("mesh", centre, half-sizes, rotation, field) in the world for the object's world
        matrix now: the field with the first frame's entry, None (kept) after it. A matrix
        that shears is taken as its nearest rotation (the core's box cannot shear)."""
        m = np.array(matrix, np.float64)
        axes = own_axes(matrix)
        if axes is None:
            u, _, vt = np.linalg.svd(m[:3, :3])
            r = u @ vt
            if np.linalg.det(r) < 0.0:
                u[:, 2] = -u[:, 2]
                r = u @ vt
            scale = np.linalg.norm(m[:3, :3], axis=0)
        else:
            r, scale = axes
        centre = m[:3, :3] @ self.centre + m[:3, 3]
        half = self.half_sizes * np.abs(scale)
        return ("mesh", tuple(map(float, centre)), tuple(map(float, half)), quaternion(r),
                self.field if first else None)


def is_box(co, lo, hi):
    """Whether every vertex sits on a corner of the vertices' box (a cube, a board)."""
    tol = 1e-5 * max(float(np.max(hi - lo)), 1e-9)
    return bool(np.all((np.abs(co - lo) <= tol) | (np.abs(co - hi) <= tol)))


def _closed(co, loops, starts, totals):
    """Whether the faces close a volume: every edge between two faces, once vertices at one
    place count as one (a curve's caps and sides, a text's letters and a metaball's sheets
    are separate pieces that meet)."""
    if len(loops) == 0:
        return False
    tol = 1e-6 * max(float(np.max(co.max(axis=0) - co.min(axis=0))), 1e-9)
    _, one = np.unique(np.round(co / tol).astype(np.int64), axis=0, return_inverse=True)
    one = one.ravel()
    after = np.arange(1, len(loops) + 1)
    after[starts + totals - 1] = starts  # each face's last corner leads to its first
    a, b = one[loops], one[loops[after]]
    edges = np.sort(np.stack([a[a != b], b[a != b]], axis=1), axis=1)
    _, counts = np.unique(edges, axis=0, return_counts=True)
    return bool(len(counts)) and bool(np.all(counts == 2))


class MeshSample:
    """An evaluated mesh at one frame, in its own unscaled coordinates: vertices ``co`` (n, 3),
    faces ``polys`` (vertex index tuples), and whether they close a volume."""

    def __init__(self, co, polys, closed):
        self.co, self.polys, self.closed = co, polys, closed


def mesh_sample(ev, boxes=True):
    """The MeshSample of an evaluated object, or None where a box serves: one without faces,
    or (``boxes``) a box-shaped mesh (every vertex on a corner of its box)."""
    mesh = ev.to_mesh()
    try:
        co = np.empty(len(mesh.vertices) * 3, np.float64)
        mesh.vertices.foreach_get("co", co)
        co = co.reshape(-1, 3)
        polys = [tuple(p.vertices) for p in mesh.polygons]
        loops = np.empty(len(mesh.loops), np.int64)
        mesh.loops.foreach_get("vertex_index", loops)
        starts = np.empty(len(mesh.polygons), np.int64)
        mesh.polygons.foreach_get("loop_start", starts)
        totals = np.empty(len(mesh.polygons), np.int64)
        mesh.polygons.foreach_get("loop_total", totals)
    finally:
        ev.to_mesh_clear()
    if not polys or len(co) < 3 or (boxes and (len(co) < 4 or
                                              is_box(co, co.min(axis=0), co.max(axis=0)))):
        return None
    return MeshSample(co, polys, _closed(co, loops, starts, totals))


def scale_of(matrix):
    """The scale along the object's own axes (signed where mirrored), also of a matrix that
    shears (its columns' lengths)."""
    axes = own_axes(matrix)
    return axes[1] if axes is not None else np.linalg.norm(np.array(matrix)[:3, :3], axis=0)


def field_boxes(samples, spacing, side=SIDE):
    """[(low, high, dims)]: the field's box of each sample (MeshSample, its scale) in metres
    along the object's own axes, the sample's box grown by two points and a spacing (so that
    the field sees a particle coming), and its points, the same count for all: at most half a
    particle spacing apart, or ``side`` along the longest side of the largest if that is
    coarser (up to MAX_DIM). (One count lets the step change one frame's field into the next
    while the box follows the shape, in place of one box holding every frame's: a mesh an
    armature walks off would be lost in its points.)"""
    pts = [s.co * scale for s, scale in samples]  # in metres (a mirrored axis flipped)
    lows = [p.min(axis=0) for p in pts]
    sizes = np.array([p.max(axis=0) - lo for p, lo in zip(pts, lows)])
    step = max(0.5 * spacing, float(sizes.max()) / (side - 1))
    pad = 2.0 * step + spacing
    dims = np.minimum(np.ceil((sizes.max(axis=0) + 2 * pad) / step).astype(int) + 1, MAX_DIM)
    return [(lo - pad, lo + size + pad, dims) for lo, size in zip(lows, sizes)]


def shape_in(sample, scale, box):
    """The MeshShape of a sample at its scale, over ``box`` (field_boxes)."""
    blo, bhi, dims = box
    axes_pts = [np.linspace(blo[a], bhi[a], dims[a]) for a in range(3)]
    tree = BVHTree.FromPolygons([tuple(p) for p in sample.co * scale], sample.polys,
                                epsilon=0.0)
    field = np.empty((dims[2], dims[1], dims[0]), np.float32)
    near, closed = tree.find_nearest, sample.closed
    for k, z in enumerate(axes_pts[2]):
        for j, y in enumerate(axes_pts[1]):
            row = field[k, j]
            for i, x in enumerate(axes_pts[0]):
                hit, normal, _, d = near((x, y, z))
                if closed and ((x - hit[0]) * normal[0] + (y - hit[1]) * normal[1] +
                               (z - hit[2]) * normal[2]) < 0.0:
                    d = -d
                row[i] = d
    # The field's border lies two points and a spacing off the mesh: outside it. Mostly
    # negative there, the normals all face in (flipped); some negative, they disagree or the
    # mesh has a hole, and no inside can be told: unsigned.
    border = np.concatenate([field[[0, -1]].ravel(), field[:, [0, -1]].ravel(),
                             field[:, :, [0, -1]].ravel()])
    if closed and np.mean(border < 0.0) > 0.5:
        field = -field
        border = -border
    signed = closed and not (border < 0.0).any()
    if closed and not signed:
        np.abs(field, out=field)
    centre_s, half_s = (blo + bhi) / 2, (bhi - blo) / 2
    return MeshShape(centre_s / scale, half_s / np.abs(scale), field, signed)


def mesh_shape(ev, spacing, side=SIDE):
    """The MeshShape of an evaluated mesh object over its own box (field_boxes), or None where
    a box serves: a box-shaped mesh, one without faces, or a world matrix that shears or
    flattens it."""
    axes = own_axes(ev.matrix_world)
    if axes is None:
        return None
    sample = mesh_sample(ev)
    if sample is None:
        return None
    return shape_in(sample, axes[1], field_boxes([(sample, axes[1])], spacing, side)[0])


def _flat_normal(co, polys):
    """The unit normal, in ``co``'s axes, of faces that all lie in one plane and mostly face
    one way (their areas' vector sum), else None."""
    centred = co - co.mean(axis=0)
    size = float(np.max(co.max(axis=0) - co.min(axis=0)))
    _, sv, vt = np.linalg.svd(centred, full_matrices=False)
    if len(sv) < 3 or sv[2] > 1e-5 * max(size, 1e-9) * np.sqrt(len(co)):
        return None
    fans = np.array([(p[0], a, b) for p in polys for a, b in zip(p[1:-1], p[2:])], np.int64)
    cross = np.cross(co[fans[:, 1]] - co[fans[:, 0]], co[fans[:, 2]] - co[fans[:, 0]])
    area, total = cross.sum(axis=0), float(np.linalg.norm(cross, axis=1).sum())
    n = vt[2]  # (each fan's triangle's area vector: their sum, and their sizes')
    if total <= 0.0 or abs(float(area @ n)) < 0.5 * total:
        return None  # faces facing both ways: no one side to pour from
    return n if area @ n > 0.0 else -n


def sheet_shape(ev, spacing, side=SIDE):
    """An open mesh (one whose faces close no volume: a plane, a grid, a bent sheet) as the
    shape an Inflow pours from or an Outflow drains into, as Mantaflow's planar flows: the
    shell within t of its faces, t just over half a particle spacing (one lattice layer, or
    two) or the field's step if that is coarser (so that the trilinear field leaves no gap
    between its points). A MeshShape with ``sheet`` = t and, for faces in one plane that
    face one way, ``flat`` their normal in the scaled own axes; None for a mesh that closes
    a volume or has no faces, or a world matrix that shears or flattens it."""
    axes = own_axes(ev.matrix_world)
    if axes is None:
        return None
    sample = mesh_sample(ev, boxes=False)
    if sample is None or sample.closed:
        return None
    flat = _flat_normal(sample.co * axes[1], sample.polys)
    # (a flat sheet's field is a few points thick: as fine as MAX_DIM allows costs little)
    box = field_boxes([(sample, axes[1])], spacing, MAX_DIM if flat is not None else side)[0]
    shape = shape_in(sample, axes[1], box)  # (unsigned: open)
    step = float(np.max((box[1] - box[0]) / (box[2] - 1)))
    # Just over half a spacing: a lattice layer always lies inside (two where the layers
    # straddle the faces, as when the lattice is centred on them), never none.
    t = max(0.55 * spacing, step)
    shape.field = (shape.field - np.float32(t)).astype(np.float32)
    shape.signed, shape.sheet, shape.flat = True, t, flat
    return shape
