"""Windshield rain on one glass: `substeps` simulation steps per frame, then the height map,
normals and wetness.

Inputs (all optional):
    fps            frames per second (default 24): a frame is 1 / fps seconds
    substeps       simulation steps per frame (default 2)
    gravity_dir    (H, W, 2|4) per glass cell: in-plane gravity (and airflow) along u, v
    mask           (H, W): 1 where there is glass (curved glass from a mesh's UV layout)
    wipers         {frame: [angle or travel per wiper]} from Blender animation
    car            {frame: (speed m/s, acceleration m/s^2)} from the car's animation
    background     (h, w, 3|4) image seen through the glass, for the refraction preview

Streams per frame:
    rain_####.exr     data: height (m), normal.x, normal.y, normal.z, wetness. Float.
    normal_####.exr   RGB: tangent-space normal map (n * 0.5 + 0.5, u/v = the glass's UV),
                      A: wetness. Half.
    height_####.exr   Y: drop height in m (bump or displacement). Float.
    preview_####.exr  RGB(A): the paper's cheap refraction of `background` (with a
                      background only). Half.
"""
import numpy as np

from .. import errors, image
from ..arrays import digest
from ..rain import Rain, refraction
from . import register
from .base import Effect, plain


@register
class RainEffect(Effect):
    name = "rain"
    streams = ("rain", "normal", "height", "preview")

    @classmethod
    def groups(cls):
        return {"rain": Rain.spec()}

    def __init__(self, params=None, inputs=None):
        super().__init__(params, inputs)
        inp = self.inputs
        fps, substeps = float(inp.get("fps", 24.0)), int(inp.get("substeps", 2))
        if not 1.0 <= fps <= 1000.0:
            raise errors.InvalidArgument(f"fps = {fps}: must be in [1, 1000]")
        if not 1 <= substeps <= 1000:
            raise errors.InvalidArgument(f"substeps = {substeps}: must be in [1, 1000]")
        self.dt = 1.0 / fps / substeps
        self.fps, self.substeps = fps, substeps
        self.rain = Rain(self.params_dict()["rain"])
        try:
            if inp.get("gravity_dir") is not None or inp.get("mask") is not None:
                self.rain.set_tangents(inp.get("gravity_dir"), inp.get("mask"))
        except BaseException:
            self.rain.close()
            raise
        self.wipers = inp.get("wipers") or {}
        self.car = inp.get("car") or {}
        self.background = inp.get("background")
        if self.background is None:
            self.streams = ("rain", "normal", "height")

    def scalar_inputs(self):
        """Frames per second and substeps: together the time step."""
        return plain({"fps": self.fps, "substeps": self.substeps})

    def scene_inputs(self):
        """The glass's shape and slope (from the mesh) and the preview's background."""
        inp = self.inputs
        out = {}
        if inp.get("gravity_dir") is not None or inp.get("mask") is not None:
            out["glass"] = digest(inp.get("gravity_dir"), inp.get("mask"))
        if self.background is not None:
            out["background"] = digest(self.background)
        return out

    def frame_inputs(self, frame):
        """The wipers' angles and the car's speed set at ``frame``."""
        return {"wipers": digest(self.wipers.get(frame)), "car": digest(self.car.get(frame))}

    def step(self, frame, progress):
        if frame in self.car:
            speed, accel = self.car[frame]
            self.rain.set_car(speed, accel)
        angles = self.wipers.get(frame)
        for k in range(self.substeps):
            if angles is not None and k == self.substeps - 1:
                self.rain.set_wiper_angles(angles)  # reached at the end of the frame
            self.rain.step(self.dt, progress)

    def outputs(self, frame):
        h = self.rain.heightmap()
        wet = self.rain.wetness()
        n = image.normal_map(h, self.rain.texel_size, edge="CLAMP")
        out = {
            "rain": ("exr", {"height": h, "normal.x": n[..., 0], "normal.y": n[..., 1],
                             "normal.z": n[..., 2], "wetness": wet}, {}),
            "normal": ("exr", {"R": n[..., 0] * 0.5 + 0.5, "G": n[..., 1] * 0.5 + 0.5,
                               "B": n[..., 2] * 0.5 + 0.5, "A": wet}, {"half": True}),
            "height": ("exr", {"Y": h}, {}),
        }
        if self.background is not None:
            pv = refraction(n, self.background)
            names = "RGBA"[:pv.shape[2]] if pv.ndim == 3 else "Y"
            chans = {c: pv[..., i] for i, c in enumerate(names)} if pv.ndim == 3 else {"Y": pv}
            out["preview"] = ("exr", chans, {"half": True})
        return out

    def water(self):
        return self.rain.water()

    def save_state(self):
        return self.rain.save_state()

    def load_state(self, data):
        self.rain.load_state(data)

    def close(self):
        self.rain.close()
