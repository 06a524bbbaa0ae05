"""A mesh's UV layout as a simulation grid: which cells are glass, each cell's tangent frame,
and the glass's physical size. Used for curved glass (rain)."""
import numpy as np


def physical_size(pos, tris, uvs):
    """(metres per unit u, metres per unit v), area-weighted over the triangles."""
    p0, p1, p2 = pos[tris[:, 0]], pos[tris[:, 1]], pos[tris[:, 2]]
    t0, t1, t2 = uvs[:, 0], uvs[:, 1], uvs[:, 2]
    du, dv = _tangents(p1 - p0, p2 - p0, t1 - t0, t2 - t0)
    area = np.linalg.norm(np.cross(p1 - p0, p2 - p0), axis=1)
    w = area / max(area.sum(), 1e-30)
    return float((np.linalg.norm(du, axis=1) * w).sum()), float((np.linalg.norm(dv, axis=1) * w).sum())


def _tangents(e1, e2, d1, d2):
    """dP/du and dP/dv per triangle from its edges in 3D (e) and UV (d)."""
    det = d1[:, 0] * d2[:, 1] - d2[:, 0] * d1[:, 1]
    det = np.where(np.abs(det) < 1e-20, 1e-20, det)
    du = (e1 * d2[:, 1:2] - e2 * d1[:, 1:2]) / det[:, None]
    dv = (e2 * d1[:, 0:1] - e1 * d2[:, 0:1]) / det[:, None]
    return du, dv


def rasterize(pos, tris, uvs, width, height, down=(0.0, 0.0, -1.0), back=None):
    """Per cell of a width x height grid over UV [0, 1]^2 (row 0 = v 0): the in-plane parts of
    `down` (and `back`, the car's backward axis) along the cell's unit u and v tangents, as
    (H, W, 2|4), and the glass mask (H, W). Cells whose centre no triangle covers are 0."""
    p0, p1, p2 = pos[tris[:, 0]], pos[tris[:, 1]], pos[tris[:, 2]]
    t0, t1, t2 = uvs[:, 0], uvs[:, 1], uvs[:, 2]
    du, dv = _tangents(p1 - p0, p2 - p0, t1 - t0, t2 - t0)
    tu = du / np.maximum(np.linalg.norm(du, axis=1, keepdims=True), 1e-30)
    # v tangent made orthogonal to u, so the two components are a proper 2D vector.
    tv = dv - (dv * tu).sum(axis=1, keepdims=True) * tu
    tv /= np.maximum(np.linalg.norm(tv, axis=1, keepdims=True), 1e-30)
    vecs = [np.asarray(down, np.float64)] + ([np.asarray(back, np.float64)] if back is not None
                                             else [])
    chans = 2 * len(vecs)
    field = np.zeros((height, width, chans), np.float32)
    mask = np.zeros((height, width), np.float32)
    for k in range(len(tris)):
        a, b, c = t0[k] * (width, height), t1[k] * (width, height), t2[k] * (width, height)
        lo = np.floor(np.minimum(np.minimum(a, b), c)).astype(int)
        hi = np.ceil(np.maximum(np.maximum(a, b), c)).astype(int)
        i0, j0 = max(lo[0], 0), max(lo[1], 0)
        i1, j1 = min(hi[0], width), min(hi[1], height)
        if i1 <= i0 or j1 <= j0:
            continue
        x, y = np.meshgrid(np.arange(i0, i1) + 0.5, np.arange(j0, j1) + 0.5)
        d = (b[1] - c[1]) * (a[0] - c[0]) + (c[0] - b[0]) * (a[1] - c[1])
        if abs(d) < 1e-20:
            continue
        l1 = ((b[1] - c[1]) * (x - c[0]) + (c[0] - b[0]) * (y - c[1])) / d
        l2 = ((c[1] - a[1]) * (x - c[0]) + (a[0] - c[0]) * (y - c[1])) / d
        inside = (l1 >= -1e-9) & (l2 >= -1e-9) & (1 - l1 - l2 >= -1e-9)
        if not inside.any():
            continue
        vals = []
        for v in vecs:
            vals += [float(v @ tu[k]), float(v @ tv[k])]
        sub = field[j0:j1, i0:i1]
        sub[inside] = vals
        mask[j0:j1, i0:i1][inside] = 1.0
    return field, mask
