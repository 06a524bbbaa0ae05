"""OpenVDB grids through pyopenvdb, written atomically.

Arrays are indexed [x, y, z] (pyopenvdb's copyFromArray order); ``voxel_size`` and ``origin``
place voxel (0, 0, 0)'s centre in world space. Vector grids carry their OpenVDB vector type
(e.g. ``velocity`` is contravariant-relative, texture coordinates are invariant).
"""
import numpy as np

from . import errors
from .bake.cache import atomic_path

VECTOR_TYPES = ("INVARIANT", "COVARIANT", "COVARIANT_NORMALIZE", "CONTRAVARIANT_RELATIVE",
                "CONTRAVARIANT_ABSOLUTE")


def _vdb():
    try:
        import pyopenvdb
    except ImportError as exc:
        raise errors.LibraryNotFound(
            "pyopenvdb is missing: install Debian's python3-openvdb (build/setup.sh does)") from exc
    return pyopenvdb


def make_grid(name, array, voxel_size=1.0, origin=(0.0, 0.0, 0.0), vector_type=None,
              grid_class="FOG_VOLUME", tolerance=0.0, metadata=None):
    """A pyopenvdb grid from a (X, Y, Z) float array or an (X, Y, Z, 3) vector array."""
    vdb = _vdb()
    array = np.ascontiguousarray(array, dtype=np.float32)
    if array.ndim == 3:
        grid = vdb.FloatGrid()
    elif array.ndim == 4 and array.shape[3] == 3:
        grid = vdb.Vec3SGrid()
        vt = vector_type or "INVARIANT"
        if vt not in VECTOR_TYPES:
            raise errors.InvalidArgument(f"vector_type = {vt!r}: must be one of "
                                         f"{', '.join(VECTOR_TYPES)}")
        grid.vectorType = getattr(vdb.VectorType, vt)
    else:
        raise errors.InvalidArgument(f"{name}: array shape {array.shape} must be (X, Y, Z) or "
                                     "(X, Y, Z, 3)")
    if not np.all(np.isfinite(array)):
        raise errors.InvalidArgument(f"{name}: contains NaN or infinite values")
    sizes = tuple(float(v) for v in np.broadcast_to(np.asarray(voxel_size, np.float64), (3,)))
    if not all(v > 0 for v in sizes):
        raise errors.InvalidArgument(f"voxel_size = {voxel_size}: must be > 0")
    grid.copyFromArray(array, tolerance=(tolerance,) * 3 if array.ndim == 4 else tolerance)
    grid.name = name
    grid.gridClass = getattr(vdb.GridClass, grid_class)
    # Voxel (i, j, k) centred at origin + (i, j, k) * voxel_size (a box may have non-cubic
    # voxels: a scale matrix, translation in the last row as OpenVDB's matrices have it).
    xform = vdb.createLinearTransform([[sizes[0], 0, 0, 0], [0, sizes[1], 0, 0],
                                       [0, 0, sizes[2], 0],
                                       [float(origin[0]), float(origin[1]), float(origin[2]), 1]])
    grid.transform = xform
    for key, value in (metadata or {}).items():
        grid[key] = value
    return grid


def write(path, grids, metadata=None):
    """Writes pyopenvdb grids (or dicts of make_grid arguments) to ``path`` atomically."""
    vdb = _vdb()
    built = [g if not isinstance(g, dict) else make_grid(**g) for g in grids]
    names = [g.name for g in built]
    if len(set(names)) != len(names):
        raise errors.InvalidArgument(f"grids: duplicate names in {names}")
    with atomic_path(path) as tmp:
        vdb.write(tmp, grids=built, metadata=metadata or {})
        _check_whole(vdb, tmp, path, names)


def _check_whole(vdb, tmp, path, names):
    """OpenVDB's writer ignores failed writes (a full disk, a file size limit): it leaves a
    cut file and no error, which would be renamed into place and recorded as a good frame.
    A cut file does not read back (its grid offsets are never filled in): refused here."""
    try:
        back = [g.name for g in vdb.readAllGridMetadata(tmp)]
    except Exception:  # pyopenvdb raises KeyError, LookupError, ... on a cut file
        back = None
    if back is None or sorted(back) != sorted(names):
        raise errors.FileIOError(f'"{path}": the file could not be written whole (is the disk '
                                 "full?)")


def read(path):
    """All grids of ``path`` as pyopenvdb grids, keyed by name."""
    grids, _meta = _vdb().readAll(path)
    return {g.name: g for g in grids}


def read_grid(path, name):
    """One grid of ``path`` as a dense array [x, y, z(, 3)] over index (0, 0, 0) to the grid's
    active bounding box's upper corner (zero where inactive)."""
    try:
        grid = _vdb().read(path, name)
    except (KeyError, LookupError) as exc:
        raise errors.FormatError(f"{path}: no grid named {name!r}") from exc
    _lo, hi = grid.evalActiveVoxelBoundingBox()
    shape = tuple(max(int(h) + 1, 1) for h in hi)
    vector = type(grid).__name__.startswith("Vec3")
    out = np.zeros(shape + ((3,) if vector else ()), np.float32)
    grid.copyToArray(out, ijk=(0, 0, 0))
    return out
