"""Shared image kernels: normal maps from height fields, and how much a UV layout overlaps."""
import ctypes

import numpy as np

from . import _lib, args, arrays, errors
from ._lib import Image, Message, P, check_message, hbk_result_t

_lib.declare([
    ("hbk_normal_map", hbk_result_t,
     [P(Image), ctypes.c_float, ctypes.c_float, ctypes.c_float, ctypes.c_int32, ctypes.c_int32,
      P(Image), P(Message)], check_message),
    ("hbk_uv_overlap", hbk_result_t,
     [P(ctypes.c_float), ctypes.c_int32, ctypes.c_int32, P(ctypes.c_float), P(Message)],
     check_message),
])

EDGES = {"CLAMP": 0, "WRAP": 1, "MIRROR": 2}


def normal_map(height, texel_size=(1.0, 1.0), strength=1.0, edge="CLAMP", encode=False,
               out=None):
    """Tangent-space normals of a (h, w) float32 height field, as (h, w, 3) or into ``out``
    ((h, w, 3|4)). ``encode`` maps to n * 0.5 + 0.5 for Blender's Normal Map node."""
    edge = EDGES[args.choice(edge, "edge", EDGES)]
    texel = args.numbers(texel_size, "texel_size", 2)
    strength = args.number(strength, "strength")
    encode = args.flag(encode, "encode")
    src = arrays.as_image(height, "height", channels=1)  # before out is shaped from it
    if out is None:
        out = np.empty(height.shape[:2] + (3,), dtype=np.float32)
    dst = arrays.as_image(out, "out", channels=(3, 4), writable=True)
    _lib.lib.hbk_normal_map(src, texel[0], texel[1], strength, edge, encode, dst, Message())
    return out


def uv_overlap(uvs, resolution=256):
    """The share (0..1) of the texels a UV layout covers that two or more of its triangles
    cover: uvs (T, 3, 2), at resolution x resolution texels. Snow and rain bake into the UVs,
    so what overlaps shows on every face that shares it."""
    uvs = args.float32_array(uvs, "uvs")
    if uvs.ndim != 3 or uvs.shape[1:] != (3, 2):
        raise errors.InvalidArgument(f"uvs: must have shape (triangles, 3, 2), got {uvs.shape}")
    out = ctypes.c_float()
    _lib.lib.hbk_uv_overlap(uvs.ctypes.data_as(P(ctypes.c_float)), len(uvs),
                            args.integer(resolution, "resolution"),
                            ctypes.byref(out), Message())
    return out.value
