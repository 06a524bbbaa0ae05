"""numpy arrays <-> C image views, checked before any call so a wrong dtype, shape or layout
raises instead of corrupting memory."""
import ctypes
import hashlib

import numpy as np

from . import _lib, args, errors
from ._lib import Image

FLOAT_PTR = ctypes.POINTER(ctypes.c_float)
# argtypes for float* / int32_t* parameters: a wrong dtype or layout fails before the call.
float_array = np.ctypeslib.ndpointer(np.float32, flags="C_CONTIGUOUS")
int_array = np.ctypeslib.ndpointer(np.int32, flags="C_CONTIGUOUS")
# hbk_image_check's limit on an image's width and height.
MAX_IMAGE_SIDE = 65536


def as_image(arr, name, channels=None, writable=False):
    """A hbk_image_t over a float32 array of shape (h, w) or (h, w, c); row 0 = bottom.

    The array must stay alive while the view is used (callers keep it referenced)."""
    if not isinstance(arr, np.ndarray):
        raise errors.InvalidArgument(f"{name}: must be a numpy array, got {type(arr).__name__}")
    if arr.dtype != np.float32:
        raise errors.InvalidArgument(f"{name}: dtype must be float32, got {arr.dtype}")
    if arr.ndim not in (2, 3):
        raise errors.InvalidArgument(f"{name}: must have shape (height, width[, channels]), got "
                                     f"{arr.shape}")
    c = 1 if arr.ndim == 2 else arr.shape[2]
    if channels is not None and c not in ((channels,) if isinstance(channels, int) else channels):
        raise errors.InvalidArgument(f"{name}: must have {channels} channel(s), got {c}")
    if not arr.flags.c_contiguous:
        raise errors.InvalidArgument(f"{name}: must be C-contiguous (use np.ascontiguousarray)")
    if writable and not arr.flags.writeable:
        raise errors.InvalidArgument(f"{name}: must be writable")
    h, w = arr.shape[:2]
    return Image(arr.ctypes.data_as(FLOAT_PTR), w, h, c, w * c)


def empty(height, width, channels=1):
    """A new zeroed float32 image buffer of the shape the kernels expect."""
    shape = (height, width) if channels == 1 else (height, width, channels)
    return np.zeros(shape, dtype=np.float32)


def grid_to_xyz(arr, threads=2):
    """A grid shaped (nz, ny, nx[, c]), x fastest as the kernels store volumes, copied to
    (nx, ny, nz[, c]), the [x, y, z] order pyopenvdb's copyFromArray takes (which ignores a
    view's strides, so a transposed view will not do). In C, tile by tile on threads: numpy's
    transposing copy took a quarter of a second a frame for a 128^3 fluid's grids."""
    if not isinstance(arr, np.ndarray) or arr.dtype != np.float32 or arr.ndim not in (3, 4):
        raise errors.InvalidArgument("grid: must be a float32 array shaped (nz, ny, nx[, c])")
    src = np.ascontiguousarray(arr)
    nz, ny, nx = src.shape[:3]
    comps = src.shape[3] if src.ndim == 4 else 1
    out = np.empty((nx, ny, nz) + src.shape[3:], np.float32)
    _lib.lib.hbk_grid_to_xyz(src.ctypes.data_as(FLOAT_PTR), out.ctypes.data_as(FLOAT_PTR),
                             nx, ny, nz, comps, args.integer(threads, "threads"),
                             _lib.Message())
    return out


def digest(*arrays):
    """A short SHA-256 of arrays (None counts as none; floats as float32, other numbers as
    int64): what a manifest records of an input too large to list."""
    h = hashlib.sha256()
    for a in arrays:
        if a is None:
            h.update(b"none")
        else:
            a = np.asarray(a)
            a = np.ascontiguousarray(a, np.float32 if a.dtype.kind == "f" else np.int64)
            h.update(repr(a.shape).encode())
            h.update(a.tobytes())
    return h.hexdigest()[:16]
