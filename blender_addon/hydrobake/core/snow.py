"""Snow attachment (hbk_snow_*): falling flakes that stick to a mesh by temperature, water
content and material, stamped into coverage and depth textures in the mesh's UV space."""
import ctypes

import numpy as np

from . import _lib, args, arrays, errors
from ._lib import Image, P, Progress
from .handle import Handle


class Material(ctypes.Structure):
    """hbk_snow_material_t: a material slot's catch chance (0..0.5), melts, sheds."""
    _fields_ = [("catch_chance", ctypes.c_float), ("melts", ctypes.c_int32),
                ("sheds", ctypes.c_int32)]


class Stats(ctypes.Structure):
    _fields_ = [(n, ctypes.c_int64) for n in ("substeps", "flake_steps", "hits", "stuck",
                                               "bounced", "melted", "shed", "fell")]

    def as_dict(self):
        return {n: getattr(self, n) for n, _ in self._fields_}


_lib.check_mirror(Material, "hbk_snow_material_t")
_lib.check_mirror(Stats, "hbk_snow_stats_t")
Handle.declare("snow", [
    ("set_materials", [P(Material), ctypes.c_int32]),
    ("set_mesh", [arrays.float_array, ctypes.c_int32, arrays.int_array, ctypes.c_void_p, ctypes.c_void_p,
                  ctypes.c_int32]),
    ("step", [ctypes.c_int32, P(Progress)]),
    ("coverage", [P(Image)]), ("depth", [P(Image)]),
    ("flakes", [ctypes.c_void_p, ctypes.c_int32, P(ctypes.c_int32)]),
])
_lib.declare([
    ("hbk_snow_texture_size", None, [ctypes.c_void_p, P(ctypes.c_int32), P(ctypes.c_int32)]),
    ("hbk_snow_stats", None, [ctypes.c_void_p, P(Stats)]),
    ("hbk_snow_water_content", ctypes.c_float, [ctypes.c_void_p, ctypes.c_float]),
    ("hbk_snow_stick_chance", ctypes.c_float, [ctypes.c_void_p, ctypes.c_float]),
    ("hbk_snow_hit_chance", ctypes.c_float, [ctypes.c_void_p, ctypes.c_float, ctypes.c_float]),
    ("hbk_snow_bleed", ctypes.c_float, [ctypes.c_void_p, ctypes.c_float]),
    ("hbk_snow_stamp_alpha", None, [ctypes.c_void_p, ctypes.c_float, ctypes.c_float,
                                    P(ctypes.c_float * 9)]),
])


class Snow(Handle):
    prefix = "snow"

    def set_materials(self, materials):
        """materials: list of (catch_chance, melts, sheds), one per material slot."""
        rows = []
        for i, m in enumerate(args.sequence(materials, "materials", what="materials")):
            name = f"materials[{i}]"
            c, melts, sheds = args.sequence(m, name, 3, "values (catch_chance, melts, sheds)")
            rows.append(Material(args.number(c, f"{name}.catch_chance"),
                                 args.flag(melts, f"{name}.melts"),
                                 args.flag(sheds, f"{name}.sheds")))
        self.call("set_materials", (Material * len(rows))(*rows), len(rows))

    def set_mesh(self, positions, triangles, uvs=None, material_index=None):
        """positions (V, 3) world space; triangles (T, 3) int; uvs (T, 3, 2) per corner;
        material_index (T,) int."""
        pos = args.float32_array(positions, "positions", 3)
        tri = args.index_array(triangles, "triangles", 3)
        keep = [pos, tri]
        uv_ptr = mi_ptr = None
        if uvs is not None:
            uv = args.float32_array(uvs, "uvs").reshape(-1)
            if uv.size != tri.shape[0] * 6:
                raise errors.InvalidArgument(f"uvs: {uv.size} values, need 6 per triangle "
                                             f"({tri.shape[0] * 6})")
            keep.append(uv)
            uv_ptr = uv.ctypes.data
        if material_index is not None:
            mi = args.index_array(material_index, "material_index").reshape(-1)
            if mi.size != tri.shape[0]:
                raise errors.InvalidArgument(f"material_index: {mi.size} values, need one per "
                                             f"triangle ({tri.shape[0]})")
            keep.append(mi)
            mi_ptr = mi.ctypes.data
        self.call("set_mesh", pos.reshape(-1), pos.shape[0], tri.reshape(-1), uv_ptr, mi_ptr,
                  tri.shape[0])

    def step(self, substeps=1, progress=None):
        self.call("step", args.integer(substeps, "substeps"), args.progress(progress))

    @property
    def texture_size(self):
        w, h = ctypes.c_int32(), ctypes.c_int32()
        _lib.lib.hbk_snow_texture_size(self.h, ctypes.byref(w), ctypes.byref(h))
        return w.value, h.value

    def coverage(self):
        w, h = self.texture_size
        out = arrays.empty(h, w, 4)
        self.call("coverage", arrays.as_image(out, "rgba", writable=True))
        return out

    def depth(self):
        w, h = self.texture_size
        out = arrays.empty(h, w, 1)
        self.call("depth", arrays.as_image(out, "depth", writable=True))
        return out

    def flakes(self):
        n = ctypes.c_int32()
        self.call("flakes", None, 0, ctypes.byref(n))
        out = np.empty((n.value, 3), np.float32)
        self.call("flakes", out.ctypes.data, n.value, ctypes.byref(n))
        return out

    def stats(self):
        s = Stats()
        _lib.lib.hbk_snow_stats(self.h, ctypes.byref(s))
        return s.as_dict()



def _params_ref(params):
    """The formulas' params: a Snow's ``params``, or None for the paper's figures."""
    if params is None:
        return None
    if not isinstance(params, Snow.spec().struct):
        raise errors.InvalidArgument(f"params: must be a Snow's params (Snow(...).params) or "
                                     f"None, got {type(params).__name__}")
    return ctypes.byref(params)


def stamp_alpha(temp_c, r, params=None):
    """The 3x3 stamp (0-255 scale) the model adds for random number r at temp_c."""
    out = (ctypes.c_float * 9)()
    _lib.lib.hbk_snow_stamp_alpha(_params_ref(params), args.number(temp_c, "temp_c"),
                                  args.number(r, "r"), out)
    return np.array(out[:], np.float32).reshape(3, 3)


def hit_chance(temp_c, catch_chance=0.0, params=None):
    return _lib.lib.hbk_snow_hit_chance(_params_ref(params), args.number(temp_c, "temp_c"),
                                        args.number(catch_chance, "catch_chance"))


def water_content(temp_c, params=None):
    return _lib.lib.hbk_snow_water_content(_params_ref(params), args.number(temp_c, "temp_c"))
