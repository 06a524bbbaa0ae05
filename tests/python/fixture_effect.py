"""A small effect for testing the bake framework on its own: a travelling wave whose normal
map comes from the real C kernel. Each step can be slowed down so cancel can land midway."""
import time

import numpy as np

from hydrobake.core import errors, image
from hydrobake.core.effects.base import Effect


class WaveEffect(Effect):
    name = "testwave"
    streams = ("wave",)

    def __init__(self, size=32, delay=0.0, fail_at=None):
        super().__init__()
        self.size, self.delay, self.fail_at = size, delay, fail_at
        self.t = None

    def params_dict(self):
        return {"size": self.size}

    def step(self, frame, progress):
        if self.fail_at == frame:
            raise errors.InvalidArgument(f"frame = {frame}: the fixture fails here on purpose")
        end = time.monotonic() + self.delay
        while time.monotonic() < end:  # a long C call polls like this
            if progress.cancel:
                raise errors.Cancelled("cancelled inside the step")
            progress.fraction = 1.0 - (end - time.monotonic()) / self.delay
            time.sleep(0.005)
        self.t = frame

    def outputs(self, frame):
        n = self.size
        x = np.linspace(0, 2 * np.pi, n, dtype=np.float32)
        h = (0.1 * np.sin(x[None, :] + 0.3 * self.t) * np.ones((n, 1), np.float32)).astype(
            np.float32)
        nm = image.normal_map(np.ascontiguousarray(h), (0.1, 0.1), encode=True)
        return {"wave": ("exr", {"height": h, "R": nm[..., 0], "G": nm[..., 1],
                                 "B": nm[..., 2]}, {"half": ("R", "G", "B")})}
