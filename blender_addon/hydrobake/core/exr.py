"""EXR files through the library's OpenEXRCore writer and reader.

Arrays are (height, width) float32 with row 0 at the bottom, as Blender's pixel buffers are.
Writes are atomic: a temporary file in the same folder is renamed over the target only when
complete, so a failed or interrupted write never leaves a partial file.
"""
import ctypes
import os
from collections.abc import Mapping

import numpy as np

from . import _lib, args, errors
from ._lib import ExrChannel, Message, P, check_message, check_handle, hbk_result_t
from .handle import Owner

COMPRESSION = {"NONE": 0, "ZIP": 1, "ZIPS": 2}


class _Reader(ctypes.Structure):
    pass


_ReaderP = P(_Reader)

_lib.declare([
    ("hbk_exr_write", hbk_result_t,
     [ctypes.c_char_p, ctypes.c_int32, ctypes.c_int32, P(ExrChannel), ctypes.c_int32,
      ctypes.c_int32, P(Message)], check_message),
    ("hbk_exr_open", hbk_result_t, [P(_ReaderP), ctypes.c_char_p, P(Message)], check_message),
    ("hbk_exr_size", None, [_ReaderP, P(ctypes.c_int32), P(ctypes.c_int32)]),
    ("hbk_exr_channel_count", ctypes.c_int32, [_ReaderP]),
    ("hbk_exr_channel_name", ctypes.c_char_p, [_ReaderP, ctypes.c_int32]),
    ("hbk_exr_channel_is_half", ctypes.c_int32, [_ReaderP, ctypes.c_int32]),
    ("hbk_exr_message", ctypes.c_char_p, [_ReaderP]),
    ("hbk_exr_close", None, [_ReaderP]),
])
_lib.declare([
    ("hbk_exr_read_channel", hbk_result_t,
     [_ReaderP, ctypes.c_char_p, _lib.P(ctypes.c_float), ctypes.c_size_t, ctypes.c_size_t],
     check_handle(_lib.lib.hbk_exr_message)),
])


def _path(path):
    """path as the bytes the C calls take."""
    try:
        b = os.fsencode(path)
    except TypeError:
        raise errors.InvalidArgument(f"path: must be a str, bytes or os.PathLike, got "
                                     f"{type(path).__name__}") from None
    if b"\0" in b:  # C would stop at it: another file's name
        raise errors.InvalidArgument(f"path: must not contain a NUL character, got {path!r}")
    return b


def write(path, channels, half=(), compression="ZIP"):
    """Writes ``channels`` (name -> (h, w) float32 array, all the same size) to ``path``.

    ``half``: names stored as 16-bit half (the rest as 32-bit float), or True for all;
    None or False for none."""
    path = _path(path)
    if not isinstance(channels, Mapping):
        raise errors.InvalidArgument(f"channels: must be a dict of name -> (height, width) "
                                     f"array, got {type(channels).__name__}")
    if not channels:
        raise errors.InvalidArgument("channels: must name at least one channel")
    compression = args.choice(compression, "compression", COMPRESSION)
    if half is None or isinstance(half, (bool, np.bool_)):
        half = list(channels) if half else ()
    elif not isinstance(half, str):  # a string is searched as before ("RGB" holds R, G, B)
        half = args.sequence(half, "half", what="channel names")
    arrays, shape = [], None
    for name, arr in channels.items():
        if not isinstance(name, str):
            raise errors.InvalidArgument(f"channels: names must be strings, got {name!r}")
        arr = args.float32_array(arr, f"channels[{name!r}]")
        if arr.ndim != 2:
            raise errors.InvalidArgument(f"channels[{name!r}]: must be 2-D (height, width), got "
                                         f"shape {arr.shape}")
        if shape is None:
            shape = arr.shape
        elif arr.shape != shape:
            raise errors.InvalidArgument(f"channels[{name!r}]: shape {arr.shape} differs from "
                                         f"{shape}")
        arrays.append((name, arr))
    table = (ExrChannel * len(arrays))()
    for i, (name, arr) in enumerate(arrays):
        table[i] = ExrChannel(name.encode(), arr.ctypes.data_as(P(ctypes.c_float)), 1,
                              shape[1], int(name in half))
    _lib.lib.hbk_exr_write(path, shape[1], shape[0], table, len(arrays),
                           COMPRESSION[compression], Message())


def write_rgba(path, rgba, half=False, compression="ZIP"):
    """Writes an (h, w, 3|4) array as R, G, B[, A] channels: what Blender loads from EXR."""
    rgba = args.float32_array(rgba, "rgba")
    if rgba.ndim != 3 or rgba.shape[2] not in (3, 4):
        raise errors.InvalidArgument(f"rgba: must have shape (height, width, 3|4), got "
                                     f"{rgba.shape}")
    names = "RGBA"[:rgba.shape[2]]
    write(path, {n: rgba[:, :, i] for i, n in enumerate(names)}, half=True if half else (),
          compression=compression)


class Reader(Owner):
    """An open EXR file: ``size``, ``channels`` (name -> is_half), ``read(name)``.

    Use as a context manager, or call close(); the file is closed when collected."""

    def __init__(self, path):
        handle = _ReaderP()
        _lib.lib.hbk_exr_open(ctypes.byref(handle), _path(path), Message())
        self._own(handle, _lib.lib.hbk_exr_close)
        w, h = ctypes.c_int32(), ctypes.c_int32()
        _lib.lib.hbk_exr_size(handle, ctypes.byref(w), ctypes.byref(h))
        self.size = (w.value, h.value)
        n = _lib.lib.hbk_exr_channel_count(handle)
        self.channels = {_lib.lib.hbk_exr_channel_name(handle, i).decode():
                         bool(_lib.lib.hbk_exr_channel_is_half(handle, i) == 1) for i in range(n)}

    def read(self, name):
        """Channel ``name`` as a (h, w) float32 array, row 0 at the bottom."""
        if not isinstance(name, str):
            raise errors.InvalidArgument(f"name: must be a channel name (a str), got "
                                         f"{type(name).__name__}")
        w, h = self.size
        out = np.empty((h, w), dtype=np.float32)
        _lib.lib.hbk_exr_read_channel(self.h, name.encode(), out.ctypes.data_as(P(ctypes.c_float)),
                                      1, w)
        return out


def read(path):
    """All channels of ``path`` as a dict name -> (h, w) float32 array."""
    with Reader(path) as r:
        return {name: r.read(name) for name in r.channels}
