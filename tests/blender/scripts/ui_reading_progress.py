"""In the real Blender UI (under Xvfb): a snow bake of a deforming mesh shows Blender's progress
cursor while it steps the scene through its frames, and lets it go before its own bake shows
progress; while another bake runs, whose progress the cursor shows, it leaves the cursor to
that bake."""
import os
import time

import bpy

import in_blender
from in_blender import ui_fail as fail
import fixture_wave

in_blender.enable()
fixture_wave.install()
from hydrobake.blender import jobs, reading_progress  # noqa: E402

tmp = in_blender.args()[0]
fixture_wave.BlenderWave.delay = 0.15
seen = []  # (label, busy, shown after the call) per frame read; ("closed", label) at close


class Spy(reading_progress.ReadingProgress):
    AFTER = 0.0

    def __call__(self, frame, done, total):
        super().__call__(frame, done, total)
        seen.append((self.label, self.busy, self.shown))

    def close(self):
        super().close()
        seen.append(("closed", self.label, self.shown))


jobs.ReadingProgress = Spy
state = {"phase": "start"}


def deforming_cube(name, x):
    bpy.ops.mesh.primitive_cube_add(location=(x, 0.0, 0.0))
    cube = bpy.context.active_object
    cube.name = name
    cube.modifiers.new("Wave", "WAVE").height = 0.05
    in_blender.snow(cube, (1, 12), 20, 32)


def invoke(win, effect, name):
    area = next(a for a in win.screen.areas if a.type == "VIEW_3D")
    with bpy.context.temp_override(window=win, area=area):
        r = bpy.ops.hydrobake.bake("INVOKE_DEFAULT", effect=effect, object_name=name)
    if r != {"RUNNING_MODAL"}:
        fail(f"{name}: invoke returned {r}")


def step():
    win = bpy.context.window_manager.windows[0]
    if state["phase"] == "start":
        bpy.ops.wm.save_as_mainfile(filepath=os.path.join(tmp, "ui.blend"))
        deforming_cube("Alone", 0.0)
        deforming_cube("Second", 4.0)
        in_blender.new_plane("Glass")
        bpy.context.scene.frame_start, bpy.context.scene.frame_end = 1, 60
        invoke(win, "snow", "Alone")  # nothing else runs: the cursor shows, then goes
        alone = [s for s in seen if s[0] == "Alone/snow"]
        if len(alone) != 12 or not all(shown for _, busy, shown in alone) or \
                seen[-1] != ("closed", "Alone/snow", False):
            fail(f"alone: {seen}")
        state["phase"], state["t0"] = "alone", time.monotonic()
        return 0.05
    if state["phase"] == "alone":
        if ("Alone", "snow") in jobs.ACTIVE:
            if time.monotonic() - state["t0"] > 60:
                fail("the first snow bake did not end")
            return 0.05
        seen.clear()
        invoke(win, "testwave", "Glass")  # runs 9 s: its progress shows meanwhile
        invoke(win, "snow", "Second")
        second = [s for s in seen if s[0] == "Second/snow"]
        if len(second) != 12 or any(shown or not busy for _, busy, shown in second):
            fail(f"while another bake ran: {seen}")
        for key in (("Glass", "testwave"), ("Second", "snow")):
            jobs.ACTIVE[key].runner.cancel()
        state["phase"], state["t0"] = "ending", time.monotonic()
        return 0.05
    if jobs.ACTIVE:
        if time.monotonic() - state["t0"] > 30:
            fail(f"still running: {list(jobs.ACTIVE)}")
        return 0.05
    print("UI READING PROGRESS OK", flush=True)
    os._exit(0)


in_blender.ui_steps(step)
