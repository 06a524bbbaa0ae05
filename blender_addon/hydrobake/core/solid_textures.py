"""Voxel solid textures (3D images) as fluid sample textures, without bpy.

A voxel texture is one tile of a tileable solid texture: an (X, Y, Z) or (X, Y, Z, C) array
covering uvw in [0, 1)^3, read from the first grid of an OpenVDB file (through pyopenvdb) or
made by the core's tileable noise. Cycles has no 3D image node, so the texture is sampled here
at every surface vertex's advected uvw and reaches the material as a colour attribute."""
import numpy as np

from . import errors, fluid
from .vdb import _vdb


def read_vdb(path):
    """The first grid of ``path`` as a dense (X, Y, Z, 3) float32 tile (a float grid becomes
    grey), over its active voxels' bounding box."""
    vdb = _vdb()
    try:
        grids, _meta = vdb.readAll(path)
    except (IOError, KeyError, LookupError, TypeError, ValueError) as exc:
        raise errors.FileIOError(f"{path}: cannot read a voxel texture ({exc})") from exc
    if not grids:
        raise errors.FormatError(f"{path}: holds no grid")
    grid = grids[0]
    lo, hi = grid.evalActiveVoxelBoundingBox()
    shape = tuple(int(h) - int(l) + 1 for l, h in zip(lo, hi))
    if min(shape) < 2:
        raise errors.FormatError(f"{path}: grid {grid.name!r} spans {shape} voxels: a voxel "
                                 "texture needs at least 2 along each axis")
    vector = type(grid).__name__.startswith("Vec3")
    out = np.zeros(shape + ((3,) if vector else ()), np.float32)
    grid.copyToArray(out, ijk=tuple(int(v) for v in lo))
    if not vector:
        out = np.repeat(out[..., None], 3, axis=3)
    return out


def write_noise_vdb(path, size=64, period=4, octaves=3, persistence=0.5, seed=0):
    """Writes the core's tileable gradient noise as a grey voxel texture (one float grid)."""
    from . import vdb
    tile = fluid.noise3d(size, period, octaves, persistence, seed)  # (z, y, x)
    vdb.write(path, [dict(name="density", array=np.ascontiguousarray(tile.transpose(2, 1, 0)),
                          voxel_size=1.0 / size)])


def sample(texture, uvw):
    """``texture`` (X, Y, Z, C) at ``uvw`` (N, 3): trilinear and periodic (the tile repeats),
    voxel centres at (i + 0.5) / X."""
    tex = np.asarray(texture, np.float32)
    n = np.array(tex.shape[:3])
    u = np.asarray(uvw, np.float64) * n - 0.5
    f0 = np.floor(u)
    f = u - f0
    i0 = f0.astype(np.int64) % n
    i1 = (i0 + 1) % n
    out = np.zeros((len(u), tex.shape[3]), np.float64)
    for dx in (0, 1):
        wx = f[:, 0] if dx else 1.0 - f[:, 0]
        ix = i1[:, 0] if dx else i0[:, 0]
        for dy in (0, 1):
            wy = f[:, 1] if dy else 1.0 - f[:, 1]
            iy = i1[:, 1] if dy else i0[:, 1]
            for dz in (0, 1):
                wz = f[:, 2] if dz else 1.0 - f[:, 2]
                iz = i1[:, 2] if dz else i0[:, 2]
                out += (wx * wy * wz)[:, None] * tex[ix, iy, iz]
    return out.astype(np.float32)


def surface_colour(texture, scale, uvw_a, uvw_b, weight):
    """A voxel texture on the surface: sampled at both advected fields (times the texture's
    scale) and cross-faded by the weight of A, as the material does for node textures."""
    a = sample(texture, np.asarray(uvw_a) * scale)
    b = sample(texture, np.asarray(uvw_b) * scale)
    w = np.asarray(weight, np.float32).reshape(-1, 1)
    return (w * a + (1.0 - w) * b).astype(np.float32)
