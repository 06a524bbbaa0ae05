"""A fixture effect for testing the bake framework inside Blender on its own: the core half
bakes a travelling wave's height and normal map through the real C kernels, the Blender half
wires the normal-map sequence into the object's material like a real effect would."""
import os
import time

import numpy as np

from hydrobake.blender import effects as beffects, registration
from hydrobake.blender.bridge import images, materials
from hydrobake.blender.effects.base import BlenderEffect
from hydrobake.core import effects, errors, image, snow
from hydrobake.core.effects.base import Effect


class WaveEffect(Effect):
    name = "testwave"
    streams = ("wave",)

    def __init__(self, params=None, inputs=None):
        super().__init__(None, inputs)
        self.delay = float((inputs or {}).get("delay", 0.0))
        self.t = 0
        # Every step after the first spends this many snow substeps in one C call (about
        # 0.25 ms each), which polls the progress's cancel flag as the effects' long calls do.
        self.c_substeps = int((inputs or {}).get("c_substeps", 0))
        self.snow = None
        if self.c_substeps:
            self.snow = snow.Snow({"flake_count": 20000, "texture_width": 16,
                                   "texture_height": 16, "threads": 1})
            self.snow.set_mesh(np.array([[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]],
                                        np.float32), np.array([[0, 1, 2], [0, 2, 3]], np.int32),
                               np.zeros((2, 3, 2), np.float32))

    def close(self):
        if self.snow is not None:
            self.snow.close()

    def step(self, frame, progress):
        if self.snow is not None and self.t:
            self.snow.step(self.c_substeps, progress)
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
        if obj.get("hbk_fixture_fail"):  # a target whose setup fails (the CLI goes on)
            raise ValueError(f"{obj.name}: the fixture cannot be set up here, on purpose")
        return params, {"delay": float(os.environ.get("HBK_FIXTURE_DELAY", cls.delay)),
                        "c_substeps": int(os.environ.get("HBK_FIXTURE_C_SUBSTEPS", 0))}

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
