"""Height-field water (hbk_water_*): Kass & Miller implicit shallow water with wet and dry
ground, sources, wind, object footprints and rain. Arrays are (height, width) float32, row 0
at the bottom (y = 0), one cell per pixel."""
import ctypes

from . import _lib, args, arrays
from ._lib import Image, P, Progress
from .handle import Handle

Handle.declare("water", [
    ("set_ground", [P(Image)]), ("set_level", [ctypes.c_float]),
    ("set_surface", [P(Image)]), ("set_depth", [P(Image)]), ("set_sources", [P(Image)]),
    ("set_acceleration", [P(Image)]), ("set_footprint", [P(Image)]),
    ("step", [P(Progress)]),
    ("get_surface", [P(Image)]), ("get_depth", [P(Image)]), ("get_velocity", [P(Image)]),
])
_lib.declare([
    ("hbk_water_volume", ctypes.c_double, [ctypes.c_void_p]),
    ("hbk_water_step_count", ctypes.c_uint64, [ctypes.c_void_p]),
])


class Water(Handle):
    prefix = "water"

    @property
    def shape(self):
        return (self.params.height, self.params.width)

    def _set(self, name, arr, channels=1):
        if arr is None:
            self.call(name, None)
            return
        label = name.replace("set_", "")
        arr = args.float32_array(arr, label)
        self.call(name, arrays.as_image(arr, label, channels=channels))

    def set_ground(self, b):
        self._set("set_ground", b)

    def set_level(self, level):
        self.call("set_level", args.number(level, "level"))

    def set_surface(self, h):
        self._set("set_surface", h)

    def set_depth(self, d):
        self._set("set_depth", d)

    def set_sources(self, ha):
        self._set("set_sources", ha)

    def set_acceleration(self, ua):
        self._set("set_acceleration", ua, channels=2)

    def set_footprint(self, depth):
        self._set("set_footprint", depth)

    def step(self, progress=None):
        self.call("step", args.progress(progress))

    def _get(self, name, channels=1):
        out = arrays.empty(*self.shape, channels)
        self.call(name, arrays.as_image(out, "out", writable=True))
        return out

    def surface(self):
        return self._get("get_surface")

    def depth(self):
        return self._get("get_depth")

    def velocity(self):
        return self._get("get_velocity", 2)

    def volume(self):
        return _lib.lib.hbk_water_volume(self.h)

    def step_count(self):
        return _lib.lib.hbk_water_step_count(self.h)

