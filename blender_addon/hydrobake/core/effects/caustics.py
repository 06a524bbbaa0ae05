"""Caustics: height-field water (hbk_water) and the light it throws on the ground
(hbk_caustics), one water step and one caustic map per frame.

Inputs (all optional, arrays (H, W) float32 on the water grid, row 0 at y = 0):
    ground      ground height in m (default flat at 0)
    level       initial water surface height in m (default 0.5 m above the lowest ground)
    footprints  {frame: (H, W) depth in m an object presses the surface down}
    sources     (H, W) water added/removed in m/s (pouring, draining)
    map_size    (width, height) of the caustic map in pixels (default 4 texels per cell)

Streams per frame:
    caustics_####.exr  R, G, B: the caustic multiplier, ground irradiance divided by what
                       level ground would get with no water (irradiance x cos of the sun's
                       zenith angle), so 1 = no change; a renderer's own sun lighting times this
                       gives the lit ground. A = 1. Half float, HDR.
    surface_####.exr   R, G, B: the water's tangent-space normal map (n * 0.5 + 0.5),
                       A: surface height above the initial level in m. Float.
    water_####.exr     data: height, depth, velocity.x, velocity.y (m, m, m/s). Float.
"""
import numpy as np

from .. import caustics, image
from ..water import Water
from . import register
from .base import Effect


@register
class CausticsEffect(Effect):
    name = "caustics"
    streams = ("caustics", "surface", "water")

    @classmethod
    def groups(cls):
        return {"water": Water.spec(), "light": caustics.spec()}

    def __init__(self, params=None, inputs=None):
        super().__init__(params, inputs)
        self.water = Water(self.params_dict()["water"])
        shape = self.water.shape
        ground = self.inputs.get("ground")
        self.ground = (np.zeros(shape, np.float32) if ground is None
                       else np.ascontiguousarray(ground, dtype=np.float32))
        if self.ground.shape != shape:
            self.close()
            raise ValueError(f"ground: shape {self.ground.shape} must match the water grid "
                             f"{shape} (water.height, water.width)")
        self.water.set_ground(self.ground)
        self.level = float(self.inputs.get("level", float(self.ground.min()) + 0.5))
        self.water.set_level(self.level)
        if self.inputs.get("sources") is not None:
            self.water.set_sources(self.inputs["sources"])
        self.footprints = self.inputs.get("footprints") or {}
        cell = self.params["water"].cell_size
        self.cell_size = float(cell)
        self.map_size = tuple(self.inputs.get("map_size", (shape[1] * 4, shape[0] * 4)))
        self.surface = None

    def step(self, frame, progress):
        fp = self.footprints.get(frame)
        self.water.set_footprint(fp)
        self.water.step(progress)
        self.surface = self.water.surface()
        self._map, self.stats = caustics.render(self.surface, self.ground, self.cell_size,
                                                self.map_size, self.params["light"], progress)

    def outputs(self, frame):
        periodic = bool(self.params["water"].periodic)
        normals = image.normal_map(self.surface, (self.cell_size, self.cell_size),
                                   edge="WRAP" if periodic else "CLAMP", encode=True)
        vel = self.water.velocity()
        m = self._map
        # Normalise to a multiplier: the renderer's sun already applies irradiance * N.L.
        light = self.params["light"]
        d = np.array(light.light_direction[:], np.float64)
        cos_z = d[2] / np.linalg.norm(d) if light.light_type == 0 else 1.0
        for c in range(3):
            m[..., c] /= max(light.irradiance[c] * cos_z, 1e-12)
        return {
            "caustics": ("exr", {"R": m[..., 0], "G": m[..., 1], "B": m[..., 2],
                                 "A": m[..., 3]}, {"half": True}),
            "surface": ("exr", {"R": normals[..., 0], "G": normals[..., 1],
                                "B": normals[..., 2], "A": self.surface - self.level}, {}),
            "water": ("exr", {"height": self.surface, "depth": self.water.depth(),
                              "velocity.x": vel[..., 0], "velocity.y": vel[..., 1]}, {}),
        }

    def save_state(self):
        return self.water.save_state()

    def load_state(self, data):
        self.water.load_state(data)

    def close(self):
        self.water.close()
