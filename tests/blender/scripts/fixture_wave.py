"""A fixture effect for testing the bake framework inside Blender on its own: the core half
bakes a travelling wave's height and normal map through the real C kernels, the Blender half
wires the normal-map sequence into the object's material like a real effect would."""
import os
import time

import numpy as np

from hydrobake.blender import effects as beffects, registration
from hydrobake.blender.bridge import images, materials
from hydrobake.blender.effects.base import BlenderEffect
from hydrobake.core import effects, errors, image
from hydrobake.core.effects.base import Effect


class WaveEffect(Effect):
    name = "testwave"
    streams = ("wave",)

    def __init__(self, params=None, inputs=None):
        super().__init__(None, inputs)
        self.delay = float((inputs or {}).get("delay", 0.0))
        self.t = 0

    def step(self, frame, progress):
        end = time.monotonic() + self.delay
        while time.monotonic() < end:
            if progress.cancel:
                raise errors.Cancelled("cancelled inside the step")
            time.sleep(0.005)
        self.t = frame

    def outputs(self, frame):
        x = np.linspace(0, 2 * np.pi, 32, dtype=np.float32)
        h = np.ascontiguousarray(np.tile(0.1 * np.sin(x + 0.3 * self.t), (32, 1)),
                                 dtype=np.float32)
        nm = image.normal_map(h, (0.1, 0.1), encode=True)
        return {"wave": ("exr", {"R": nm[..., 0], "G": nm[..., 1], "B": nm[..., 2],
                                 "height": h}, {})}


class BlenderWave(BlenderEffect):
    name = "testwave"
    label = "Test Wave"
    delay = 0.0

    @classmethod
    def prepare(cls, context, obj, settings, params, frames):
        return params, {"delay": float(os.environ.get("HBK_FIXTURE_DELAY", cls.delay))}

    @classmethod
    def apply(cls, context, obj, settings, folder, manifest):
        frames = sorted(int(f) for f in manifest["frames"])
        mat = materials.ensure_material(obj, "HBK_TestWave")
        tex = materials.add_node(mat.node_tree, "ShaderNodeTexImage", "testwave.normal")
        tex.image = images.load_sequence(folder, "wave", frames[0], len(frames),
                                         name=f"HBK_{obj.name}_wave")
        images.configure_user(tex.image_user, frames[0], len(frames))

    @classmethod
    def remove(cls, context, obj, settings):
        for slot in obj.material_slots:
            if slot.material and slot.material.node_tree:
                materials.remove_tagged(slot.material.node_tree, "testwave.")


def install():
    effects.register(WaveEffect)
    beffects.register_effect(BlenderWave)
    registration.unregister()
    registration.register()
