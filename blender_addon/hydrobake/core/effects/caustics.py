"""Caustics: height-field water (hbk_water) and the light it throws on the ground
(hbk_caustics), one water step and one caustic map per frame.

Inputs (all optional, arrays (H, W) float32 on the water grid, row 0 at y = 0):
    ground      ground height in m (default flat at 0)
    ground_path {frame: (H, W)} the ground's heights from that frame on, for a ground that
                moves or changes shape (after the first frame). The water keeps its depth
                over it: a rising floor lifts the water above it, and the volume is kept.
    level       initial water surface height in m (default 0.5 m above the lowest ground)
    footprints  {frame: (H, W) depth in m an object presses the surface down}
    sources     (H, W) water added/removed in m/s (pouring, draining)
    sources_path {frame: (H, W)} the sources from that frame on, for a source that moves
    map_size    (width, height) of the caustic map in pixels (default 4 texels per cell)
    view        {"camera": (x, y, z) in the grid's frame, "texture": (h, w, 3) ground colour,
                 "environment": (h, w, 3) lat-long sky or None, "heading": the grid's x axis
                 from the sky's x, radians about z (default 0)}: also bake the paper's
                rendering of the water from that camera (view refraction onto the lit
                ground, Fresnel reflection of the sky) as `view_####.exr`
    loop        (first frame, last frame, blend frames): a seamless loop. The water runs
                `blend` frames of pre-roll before the first frame; the last `blend` frames
                cross-fade the height field towards the pre-roll (heights, not maps: caustics
                do not blend linearly), so the frame after the last is the first again.

Streams per frame:
    caustics_####.exr  R, G, B: the caustic multiplier, ground irradiance divided by what
                       level ground would get with no water (irradiance x cos of the sun's
                       zenith angle), so 1 = no change; a renderer's own sun lighting times this
                       gives the lit ground. A = 1. Half float, HDR.
    surface_####.exr   R, G, B: the water's tangent-space normal map (n * 0.5 + 0.5),
                       A: surface height above the initial level in m. Float.
    height_####.exr    Y: surface height above the initial level in m (grey in Blender, for a
                       Displace modifier). Float.
    water_####.exr     data: height, depth, velocity.x, velocity.y (m, m, m/s). Float.
"""
import struct

import numpy as np

from .. import caustics, errors, image
from ..arrays import digest
from ..water import Water
from . import register
from .base import Effect, plain


@register
class CausticsEffect(Effect):
    name = "caustics"
    streams = ("caustics", "surface", "height", "water")

    @classmethod
    def groups(cls):
        return {"water": Water.spec(), "light": caustics.spec()}

    def __init__(self, params=None, inputs=None):
        super().__init__(params, inputs)
        self.water = Water(self.params_dict()["water"])
        self.workspace = caustics.Workspace()
        shape = self.water.shape
        ground = self.inputs.get("ground")
        self.ground = (np.zeros(shape, np.float32) if ground is None
                       else np.ascontiguousarray(ground, dtype=np.float32))
        if self.ground.shape != shape:
            self.close()
            raise ValueError(f"ground: shape {self.ground.shape} must match the water grid "
                             f"{shape} (water.height, water.width)")
        self.water.set_ground(self.ground)
        self.first_ground = self.ground
        self.ground_path = self._path("ground_path", shape, 1e6, "m")
        self.sources_path = self._path("sources_path", shape, 1e3, "m/s")
        self.level = float(self.inputs.get("level", float(self.ground.min()) + 0.5))
        self.water.set_level(self.level)
        if self.inputs.get("sources") is not None:
            self.water.set_sources(self.inputs["sources"])
        self.footprints = self.inputs.get("footprints") or {}
        cell = self.params["water"].cell_size
        self.cell_size = float(cell)
        self.map_size = tuple(self.inputs.get("map_size", (shape[1] * 4, shape[0] * 4)))
        self.surface = None
        self.view = self.inputs.get("view")
        if self.view is None:
            self.streams = ("caustics", "surface", "height", "water")
        else:
            self.streams = ("caustics", "surface", "height", "water", "view")
        self.loop = self.inputs.get("loop")
        self.preroll = None  # surfaces of the `blend` frames before the first (loop only)
        if self.loop is not None:
            first, last, blend = (int(v) for v in self.loop)
            if last <= first:  # no blend is allowed then: say what is wrong
                self.close()
                raise errors.InvalidArgument(
                    f"loop = frames {first}..{last}: a loop needs at least 2 frames (bake a "
                    "longer frame range, or turn Loop off)")
            if not 1 <= blend <= last - first:
                self.close()
                raise errors.InvalidArgument(
                    f"loop blend = {blend}: must be in [1, {last - first}] (frames in the loop "
                    "minus one)")
            self.loop = (first, last, blend)

    def _path(self, name, shape, limit, unit):
        """{frame: (H, W) float32} of the input ``name``, each checked against the grid and
        the water's range for it (here, not when the bake reaches that frame)."""
        out = {}
        for f, a in sorted((self.inputs.get(name) or {}).items()):
            a = np.ascontiguousarray(a, dtype=np.float32)
            bad = None
            if a.shape != shape:
                bad = (f"{name}[{f}]: shape {a.shape} must match the water grid {shape} "
                       "(water.height, water.width)")
            elif not np.all(np.abs(a) <= limit):
                at = tuple(int(i) for i in np.argwhere(~(np.abs(a) <= limit))[0])
                bad = (f"{name}[{f}]{list(at)} = {a[at]:g}: must be a finite number in "
                       f"[-{limit:g}, {limit:g}] {unit}")
            if bad is not None:
                self.close()
                raise ValueError(bad)
            out[int(f)] = a
        return out

    @staticmethod
    def _at(path, first, frame):
        """A path's array at ``frame``: the latest of its frames up to it, else ``first``."""
        at = [f for f in path if f <= frame]
        return path[max(at)] if at else first

    def scalar_inputs(self):
        """The map size (the panel's Map Resolution), the starting level, the loop and the
        preview camera: a resume with any of them changed would not continue this bake."""
        view = None if self.view is None else {
            "camera": [float(c) for c in self.view["camera"]],
            "heading": float(self.view.get("heading", 0.0))}
        return plain({"map_size": self.map_size, "level": self.level, "loop": self.loop,
                      "view": view})

    def scene_inputs(self):
        """The ground's heights, the sources, the preview's ground colour and sky, and what
        floating objects press into a loop's pre-roll."""
        out = {"ground": digest(self.ground)}
        if self.inputs.get("sources") is not None:
            out["sources"] = digest(self.inputs["sources"])
        if self.view is not None:
            out["view texture"] = digest(self.view["texture"])
            out["view sky"] = digest(self.view.get("environment"))
        if self.loop is not None and self.footprints:  # (the pre-roll is in the checkpoint)
            first, _, blend = self.loop
            out["pre-roll footprints"] = digest(*(self.footprints.get(f)
                                                  for f in range(first - blend, first)))
        return out

    def frame_inputs(self, frame):
        """What floating objects press into the water at ``frame``, and where a moving ground
        is then."""
        out = {"footprint": digest(self.footprints.get(frame))}
        if self.ground_path:
            out["ground"] = digest(self._at(self.ground_path, self.first_ground, frame))
        if self.sources_path:
            out["sources"] = digest(self._at(self.sources_path, self.inputs.get("sources"),
                                             frame))
        return out

    def step(self, frame, progress):
        if self.loop is not None and self.preroll is None:
            first, _, blend = self.loop
            roll = []
            for f in range(first - blend, first):
                self.water.set_footprint(self.footprints.get(f))
                self.water.step(progress)
                roll.append(self.water.surface())
            self.preroll = np.stack(roll)
        # (set every frame: a resumed state holds those of its own frame)
        if self.ground_path:
            self.ground = self._at(self.ground_path, self.first_ground, frame)
            self.water.set_ground(self.ground)
        if self.sources_path:
            self.water.set_sources(self._at(self.sources_path, self.inputs.get("sources"),
                                            frame))
        fp = self.footprints.get(frame)
        self.water.set_footprint(fp)
        self.water.step(progress)
        self.surface = self.water.surface()
        self._depth, self._velocity = self.water.depth(), self.water.velocity()
        if self.loop is not None:
            first, last, blend = self.loop
            if frame > last - blend:
                a = (frame - (last - blend)) / blend
                target = self.preroll[frame - (last - first + 1) - first + blend]
                self.surface = ((1.0 - a) * self.surface + a * target).astype(np.float32)
                self._depth = np.maximum(self.surface - self.ground, 0.0).astype(np.float32)
                self._velocity = ((1.0 - a) * self._velocity).astype(np.float32)
        self._map, self.stats = caustics.render(self.surface, self.ground, self.cell_size,
                                                self.map_size, self.params["light"], progress,
                                                workspace=self.workspace)

    def outputs(self, frame):
        periodic = bool(self.params["water"].periodic)
        normals = image.normal_map(self.surface, (self.cell_size, self.cell_size),
                                   edge="WRAP" if periodic else "CLAMP", encode=True)
        vel = self._velocity
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
            "height": ("exr", {"Y": self.surface - self.level}, {}),
            **self._view_output(m),
            "water": ("exr", {"height": self.surface, "depth": self._depth,
                              "velocity.x": vel[..., 0], "velocity.y": vel[..., 1]}, {}),
        }

    def _view_output(self, multiplier):
        if self.view is None:
            return {}
        img = caustics.view_image(self.surface, self.ground, self.cell_size,
                                  self.view["camera"], self.view["texture"], multiplier,
                                  self.view.get("environment"), self.params["light"],
                                  heading=float(self.view.get("heading", 0.0)))
        return {"view": ("exr", {c: img[..., i] for i, c in enumerate("RGB")}, {"half": True})}

    def save_state(self):
        """The water's state, then the loop's pre-roll surfaces (if any)."""
        water = self.water.save_state()
        roll = b"" if self.preroll is None else self.preroll.astype(np.float32).tobytes()
        return struct.pack("<QQ", len(water), len(roll)) + water + roll

    def load_state(self, data):
        nw, nr = struct.unpack_from("<QQ", data)
        self.water.load_state(data[16:16 + nw])
        if nr:
            self.preroll = np.frombuffer(data[16 + nw:16 + nw + nr], np.float32).reshape(
                (-1,) + self.water.shape).copy()

    def close(self):
        self.water.close()
        self.workspace.close()
