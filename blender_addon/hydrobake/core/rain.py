"""Windshield rain (hbk_rain_*): drops that meander, merge and leave trails on a grid of glass
cells, particles swept by wipers, baked into a compressed metaball height map, wetness and the
paper's cheap refraction preview. Positions in metres from the glass's lower left corner."""
import ctypes

import numpy as np

from . import _lib, args, arrays, errors
from ._lib import Image, Message, P, Progress, check_message
from .handle import Handle

# hbk_rain_params_check's limit on width x height: past it a bake outgrows a workstation.
MAX_CELLS = 4096 * 4096


class Water(ctypes.Structure):
    """hbk_rain_water_t, in mg: rain_in = on_glass + wiped + run_off."""
    _fields_ = [(n, ctypes.c_double) for n in ("rain_in", "on_glass", "wiped", "run_off",
                                                "in_drops", "in_particles", "in_film")] + \
               [(n, ctypes.c_int64) for n in ("drops", "trails", "particles")]

    def as_dict(self):
        return {n: getattr(self, n) for n, _ in self._fields_}


class Drop(ctypes.Structure):
    _fields_ = [("x", ctypes.c_float), ("y", ctypes.c_float), ("mass", ctypes.c_float),
                ("radius", ctypes.c_float), ("speed", ctypes.c_float), ("kind", ctypes.c_int32),
                ("id", ctypes.c_uint64)]


class Blade(ctypes.Structure):
    _fields_ = [(n, ctypes.c_float) for n in ("x0", "y0", "x1", "y1", "width", "value")]


for _cls, _name in ((Water, "hbk_rain_water_t"), (Drop, "hbk_rain_drop_t"),
                    (Blade, "hbk_rain_blade_t")):
    _lib.check_mirror(_cls, _name)
Handle.declare("rain", [
    ("set_tangents", [P(Image), P(Image)]),
    ("set_wiper_angles", [P(ctypes.c_float), ctypes.c_int32]),
    ("set_car", [ctypes.c_float, ctypes.c_float, P(ctypes.c_float * 2)]),
    ("add_drop", [ctypes.c_float, ctypes.c_float, ctypes.c_float]),
    ("step", [ctypes.c_float, P(Progress)]),
    ("heightmap", [P(Image)]), ("wetness", [P(Image)]),
])
_lib.declare([
    ("hbk_rain_water", _lib.hbk_result_t, [ctypes.c_void_p, P(Water)]),
    ("hbk_rain_drop_count", ctypes.c_int64, [ctypes.c_void_p]),
    ("hbk_rain_drops", _lib.hbk_result_t, [ctypes.c_void_p, P(Drop), ctypes.c_int64,
                                           P(ctypes.c_int64)]),
    ("hbk_rain_blades", ctypes.c_int32, [ctypes.c_void_p, P(Blade), ctypes.c_int32]),
    ("hbk_rain_kernel", ctypes.c_float, [ctypes.c_float]),
    ("hbk_rain_compress", ctypes.c_float, [ctypes.c_void_p, ctypes.c_float]),
    ("hbk_rain_refraction", _lib.hbk_result_t,
     [P(Image), P(Image), ctypes.c_float, P(Image), P(Message)], check_message),
])


class Rain(Handle):
    prefix = "rain"

    @property
    def map_shape(self):
        return (self.params.map_height, self.params.map_width)

    @property
    def texel_size(self):
        p = self.params
        return (p.width * p.cell_size / p.map_width, p.height * p.cell_size / p.map_height)

    def set_tangents(self, gravity_dir=None, mask=None):
        """Curved glass: (H, W, 2|4) in-plane gravity (and airflow) per cell, (H, W) mask."""
        g = None if gravity_dir is None else args.float32_array(gravity_dir, "gravity_dir")
        m = None if mask is None else args.float32_array(mask, "mask")
        self.call("set_tangents",
                  None if g is None else arrays.as_image(g, "gravity_dir", (2, 4)),
                  None if m is None else arrays.as_image(m, "mask", 1))

    def set_wiper_angles(self, values):
        arr = args.numbers(values, "values")
        self.call("set_wiper_angles", arr, len(arr))

    def set_car(self, speed, accel, wind=None):
        w = None if wind is None else args.numbers(wind, "wind", 2)
        self.call("set_car", args.number(speed, "speed"), args.number(accel, "accel"), w)

    def add_drop(self, x, y, mass):
        self.call("add_drop", args.number(x, "x"), args.number(y, "y"),
                  args.number(mass, "mass"))

    def step(self, dt, progress=None):
        self.call("step", args.number(dt, "dt"), args.progress(progress))

    def heightmap(self):
        out = arrays.empty(*self.map_shape)
        self.call("heightmap", arrays.as_image(out, "height", writable=True))
        return out

    def wetness(self):
        out = arrays.empty(*self.map_shape)
        self.call("wetness", arrays.as_image(out, "wetness", writable=True))
        return out

    def water(self):
        w = Water()
        _lib.lib.hbk_rain_water(self.h, ctypes.byref(w))
        return w.as_dict()

    def drops(self):
        n = _lib.lib.hbk_rain_drop_count(self.h)
        buf = (Drop * max(n, 1))()
        got = ctypes.c_int64()
        _lib.lib.hbk_rain_drops(self.h, buf, n, ctypes.byref(got))
        return [{f: getattr(buf[i], f) for f, _ in Drop._fields_} for i in range(got.value)]

    def blades(self):
        buf = (Blade * 2)()
        n = _lib.lib.hbk_rain_blades(self.h, buf, 2)
        return [{f: getattr(buf[i], f) for f, _ in Blade._fields_} for i in range(n)]



def refraction(normals, background, strength=0.05):
    """The paper's cheap refraction: background looked up at an offset by the normals'
    in-plane parts, mirrored at the edges. normals (h, w, 3|4) unit (not encoded)."""
    n = args.float32_array(normals, "normals")
    bg = args.float32_array(background, "background")
    # The views first: they check the shapes out is made from.
    n_img, bg_img = arrays.as_image(n, "normals", (3, 4)), arrays.as_image(bg, "background")
    out = np.empty(n.shape[:2] + (bg.shape[2] if bg.ndim == 3 else 1,), np.float32)
    if out.shape[2] == 1:
        out = out[..., 0]
    _lib.lib.hbk_rain_refraction(n_img, bg_img, args.number(strength, "strength"),
                                 arrays.as_image(out, "out", writable=True), Message())
    return out


def kernel(q):
    return _lib.lib.hbk_rain_kernel(args.number(q, "q"))


def compress(v, params=None):
    """The map's compression passes applied to one value v; params: a Rain's ``params``
    (None: the defaults)."""
    if params is not None and not isinstance(params, Rain.spec().struct):
        raise errors.InvalidArgument(f"params: must be a Rain's params (Rain(...).params) or "
                                     f"None, got {type(params).__name__}")
    return _lib.lib.hbk_rain_compress(ctypes.byref(params) if params is not None else None,
                                      args.number(v, "v"))
