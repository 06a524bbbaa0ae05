"""In the real Blender UI (under Xvfb, events simulated): a bake that steps a slow scene
through its frames reads them from a timer, so the UI keeps ticking and Esc stops it between
frames: nothing is baked or marked, and the scene is back on its frame. Left alone, the same
bake reads every frame and then bakes them."""
import os
import time

import bpy

import in_blender
from in_blender import ui_fail as fail

in_blender.enable()
from hydrobake.blender import jobs  # noqa: E402

tmp = in_blender.args()[0]
state = {"phase": "start", "ticks": []}


def slow(_scene, _graph=None):
    time.sleep(0.05)  # a heavy scene: 60 frames take 3 s to step through


def invoke(win):
    area = next(a for a in win.screen.areas if a.type == "VIEW_3D")
    with bpy.context.temp_override(window=win, area=area):
        r = bpy.ops.hydrobake.bake("INVOKE_DEFAULT", effect="snow", object_name="Slow")
    if r != {"RUNNING_MODAL"}:
        fail(f"invoke returned {r}")


def left_nothing(scene, settings):
    return (not jobs.READING and not jobs.ACTIVE and scene.frame_current == 7 and
            jobs.BAKING not in settings and not settings.is_baked and
            not os.path.isdir(bpy.path.abspath(jobs.folder_of(settings.id_data, "snow"))))


def step():
    now = time.monotonic()
    state["ticks"].append(now)
    win = bpy.context.window_manager.windows[0]
    scene = bpy.context.scene
    if state["phase"] == "start":
        bpy.ops.wm.save_as_mainfile(filepath=os.path.join(tmp, "ui.blend"))
        bpy.ops.mesh.primitive_cube_add()
        cube = bpy.context.active_object
        cube.name = "Slow"
        cube.modifiers.new("Wave", "WAVE").height = 0.05  # read at every frame
        in_blender.snow(cube, (1, 60), 20, 32)
        scene.frame_set(7)
        bpy.app.handlers.frame_change_pre.append(slow)
        invoke(win)
        if not jobs.READING or jobs.ACTIVE:
            fail(f"not reading after invoke: {jobs.READING}, {list(jobs.ACTIVE)}")
        state.update(phase="reading", t0=now)
        return 0.02
    settings = bpy.data.objects["Slow"].hydrobake_snow
    if state["phase"] == "reading":
        if not jobs.READING:
            fail("the reading ended before Esc")
        if now - state["t0"] > 0.6:
            reading = next(iter(jobs.READING))
            if reading.last is None or not 2 <= reading.last[1] < 60:
                fail(f"read {reading.last} after {now - state['t0']:.2f}s")
            win.event_simulate(type="ESC", value="PRESS")
            win.event_simulate(type="ESC", value="RELEASE")
            state.update(phase="cancelled", t_esc=now)
        return 0.02
    if state["phase"] == "cancelled":
        if not left_nothing(scene, settings):
            if now - state["t_esc"] > 3:
                fail(f"Esc left: reading {jobs.READING}, active {list(jobs.ACTIVE)}, frame "
                     f"{scene.frame_current}, marked {jobs.BAKING in settings}, baked "
                     f"{settings.is_baked}")
            return 0.02
        gaps = [b - a for a, b in zip(state["ticks"], state["ticks"][1:])]
        print(f"UI reading cancelled after {now - state['t_esc']:.3f}s, worst UI gap "
              f"{max(gaps):.3f}s", flush=True)
        if max(gaps) > 2.0:  # reading at once would stall the UI for the whole 3 s
            fail(f"the UI stalled: {max(gaps):.3f}s")
        invoke(win)
        state.update(phase="whole", t0=now)
        return 0.05
    if state["phase"] == "whole":
        if jobs.READING or jobs.ACTIVE:
            if now - state["t0"] > 90:
                fail("the second bake did not end")
            return 0.05
        if not settings.is_baked or scene.frame_current != 7:
            fail(f"baked {settings.is_baked}, frame {scene.frame_current}")
        print("UI READING CANCEL OK", flush=True)
        os._exit(0)


in_blender.ui_steps(step)
