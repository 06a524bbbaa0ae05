"""Blender's Mantaflow liquid caches as the fluid's VELOCITY_GRID source, without bpy.

Per frame: the domain's MAC velocity from its OpenVDB data cache (read through pyopenvdb),
resampled in m/s to the texturing grid's vertices, and a surface field built from where the
liquid surface crosses each vertical line of vertices (found in Blender, which owns the mesh).

Units: Mantaflow stores velocities in cells per Mantaflow time unit, and one second of Blender
time is 1 / 2.5 of those units (Blender's fluid script: "frameLengthRaw = 0.1 * 25", dt = 0.1
at 25 fps), so the simulated velocity is v_manta * cell size * 2.5 m/s. A domain's time scale
slows the simulation: a frame then spans time_scale / fps simulated seconds, so the velocity
that moves the textures by the liquid's own motion per frame is that times time_scale.
"""
import os

import numpy as np

from . import errors
from .arrays import digest
from .bake.cache import file_checksum
from .vdb import _vdb

SECONDS_PER_MANTA_TIME = 2.5


def data_path(cache_dir, frame):
    return os.path.join(cache_dir, "data", f"fluid_data_{int(frame):04d}.vdb")


def read_velocity(path):
    """(velocity (X, Y, Z, 3) in cells per Mantaflow time unit, base resolution (X, Y, Z)).

    Only the velocity grid is read: the file also holds FLIP particles, which pyopenvdb
    cannot load."""
    if not os.path.isfile(path):
        raise errors.FileIOError(f"{path}: no Mantaflow data for this frame (bake the liquid "
                                 "domain's cache first)")
    vdb = _vdb()
    try:
        grid = vdb.read(path, "velocity")
    except (KeyError, LookupError, ValueError, TypeError, IOError) as exc:
        raise errors.FormatError(f"{path}: no readable 'velocity' grid ({exc})") from exc
    res = grid.metadata.get("file_base_resolution")
    if res is None:
        raise errors.FormatError(f"{path}: no file_base_resolution: not a Mantaflow cache")
    res = tuple(int(r) for r in res)
    dense = np.zeros(res + (3,), np.float32)
    grid.copyToArray(dense, ijk=(0, 0, 0))
    return dense, res


def _trilinear(a, u):
    """a (X, Y, Z) sampled at continuous indices u (..., 3), clamped at the edges."""
    n = np.array(a.shape, np.float64)
    u = np.clip(u, 0.0, n - 1.0)
    i0 = np.minimum(np.floor(u).astype(np.int64), np.array(a.shape) - 2).clip(0)
    f = u - i0
    if any(s == 1 for s in a.shape):  # a flat axis: nothing to interpolate along it
        f = np.where(np.array(a.shape) == 1, 0.0, f)
        i0 = np.where(np.array(a.shape) == 1, 0, i0)
    i1 = np.minimum(i0 + 1, np.array(a.shape) - 1)
    out = 0.0
    for dx in (0, 1):
        wx = f[..., 0] if dx else 1.0 - f[..., 0]
        ix = i1[..., 0] if dx else i0[..., 0]
        for dy in (0, 1):
            wy = f[..., 1] if dy else 1.0 - f[..., 1]
            iy = i1[..., 1] if dy else i0[..., 1]
            for dz in (0, 1):
                wz = f[..., 2] if dz else 1.0 - f[..., 2]
                iz = i1[..., 2] if dz else i0[..., 2]
                out = out + wx * wy * wz * a[ix, iy, iz]
    return out


def vertex_positions(box_min, box_max, resolution):
    """World positions (nz+1, ny+1, nx+1, 3) of the texturing grid's vertices."""
    lo, hi = np.asarray(box_min, np.float64), np.asarray(box_max, np.float64)
    axes = [np.linspace(lo[a], hi[a], int(resolution[a]) + 1) for a in range(3)]
    z, y, x = np.meshgrid(axes[2], axes[1], axes[0], indexing="ij")
    return np.stack([x, y, z], axis=-1)


def velocity_at(dense, domain_min, domain_max, points, time_scale=1.0, matrix=None):
    """The MAC velocity (cells per time unit) at world ``points`` (..., 3), in world m/s of
    animation time (simulated m/s times the domain's time scale).

    The grid spans [domain_min, domain_max] in the domain object's own space, which
    ``matrix`` (4 x 4, object to world; None: the identity) places in the world: a domain
    turned, scaled or moved simulates along its own axes, and its velocity is turned into
    the world's. Component a of cell (i, j, k) sits on the cell's lower face along a, at
    domain_min + h * ((i, j, k) + 0.5 - 0.5 e_a) (object space)."""
    res = np.array(dense.shape[:3], np.float64)
    lo = np.asarray(domain_min, np.float64)
    h = (np.asarray(domain_max, np.float64) - lo) / res
    m = np.eye(4) if matrix is None else np.asarray(matrix, np.float64).reshape(4, 4)
    pts = np.asarray(points, np.float64)
    if matrix is not None:  # world -> object space
        inv = np.linalg.inv(m)
        pts = pts @ inv[:3, :3].T + inv[:3, 3]
    local = np.empty(pts.shape, np.float64)  # object-space units per s
    for a in range(3):
        u = (pts - lo) / h - 0.5
        u[..., a] += 0.5
        local[..., a] = _trilinear(dense[..., a], u) * h[a] * SECONDS_PER_MANTA_TIME * time_scale
    # The object's axes in the world (their lengths carry its scale).
    return (local @ m[:3, :3].T).astype(np.float32)


def surface_field(crossings, counts, z_levels, cell_z):
    """Surface field at the vertices (nz+1, ny+1, nx+1) from the liquid surface's crossings of
    each vertical line of vertices: ``counts`` (ny+1, nx+1) crossings per line, ``crossings``
    their heights, line after line, ascending within a line. Inside the liquid (between the
    1st and 2nd crossing, the 3rd and 4th, ...) the field is above 0.5, outside below, and it
    is exactly 0.5 at each crossing: 0.5 + signed distance / (2 cell_z), clamped to [0, 1]."""
    counts = np.asarray(counts)
    ny1, nx1 = counts.shape
    z = np.asarray(z_levels, np.float64)
    field = np.zeros((len(z), ny1, nx1), np.float32)
    starts = np.concatenate([[0], np.cumsum(counts.ravel())])
    zs = np.asarray(crossings, np.float64)
    for line in np.nonzero(counts.ravel())[0]:
        c = zs[starts[line]:starts[line + 1]]
        if len(c) % 2:
            c = c[:-1]  # an open surface: ignore the unmatched last crossing
        if not len(c):
            continue
        # Distance to the nearest crossing, positive inside.
        d = np.min(np.abs(z[:, None] - c[None, :]), axis=1)
        inside = (np.searchsorted(c, z, side="right") % 2) == 1
        sd = np.where(inside, d, -d)
        j, i = divmod(int(line), nx1)
        field[:, j, i] = np.clip(0.5 + sd / (2.0 * cell_z), 0.0, 1.0)
    return field


class CacheSource:
    """{frame: (V_m (nz+1, ny+1, nx+1, 3) m/s, surface field or None)}, read when asked (a bake
    holds one frame at a time), for the fluid effect's ``velocity`` input.

    ``surfaces``: {frame: (crossings, counts)} from Blender, or None for no surface.
    ``domain_min``, ``domain_max``: the liquid domain's box in its object space, which
    ``matrix`` (object to world, None: the identity) places in the world."""

    def __init__(self, cache_dir, frames, domain_min, domain_max, box_min, box_max,
                 resolution, surfaces=None, time_scale=1.0, matrix=None):
        self.cache_dir = cache_dir
        self.frames = set(int(f) for f in frames)
        self.domain = (np.asarray(domain_min, np.float64), np.asarray(domain_max, np.float64))
        self.matrix = None if matrix is None else np.asarray(matrix, np.float64).reshape(4, 4)
        self.points = vertex_positions(box_min, box_max, resolution)
        self.z_levels = self.points[:, 0, 0, 2]
        self.cell_z = (float(box_max[2]) - float(box_min[2])) / int(resolution[2])
        self.surfaces = surfaces or {}
        self.time_scale = float(time_scale)

    def __contains__(self, frame):
        return int(frame) in self.frames

    def digest(self, frame):
        """A short SHA-256 of what frame's grids are made from: its cache file's bytes (not
        the grids, which take far longer to make), the surface's crossings and the domain's
        placement."""
        try:
            data = np.frombuffer(bytes.fromhex(file_checksum(data_path(self.cache_dir, frame))),
                                 np.uint8)
        except OSError:
            data = None  # (the step says what is wrong)
        surf = self.surfaces.get(int(frame)) or ()
        return digest(data, *surf, *self.domain, self.matrix, self.time_scale)

    def __getitem__(self, frame):
        if frame not in self:
            raise KeyError(frame)
        dense, _res = read_velocity(data_path(self.cache_dir, frame))
        vel = velocity_at(dense, *self.domain, self.points, self.time_scale, self.matrix)
        surf = self.surfaces.get(int(frame))
        field = None
        if surf is not None:
            field = surface_field(surf[0], surf[1], self.z_levels, self.cell_z)
        return vel, field
