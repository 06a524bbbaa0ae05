"""In the real Blender UI (under Xvfb, events simulated): Bake runs modal off the main thread,
the UI keeps ticking, Esc cancels within a fraction of a second, earlier frames are intact."""
import os
import time

import bpy

import in_blender
from in_blender import ui_fail as fail
import fixture_wave

in_blender.enable()
fixture_wave.install()
from hydrobake.blender import jobs  # noqa: E402
from hydrobake.core.bake import BakeCache  # noqa: E402

tmp = in_blender.args()[0]
fixture_wave.BlenderWave.delay = 0.15
state = {"phase": "start", "ticks": [], "t_esc": None}


def step():
    now = time.monotonic()
    if state["phase"] != "start":  # UI responsiveness is measured while the bake runs
        state["ticks"].append(now)
    win = bpy.context.window_manager.windows[0]
    if state["phase"] == "start":
        bpy.ops.wm.save_as_mainfile(filepath=os.path.join(tmp, "ui.blend"))
        in_blender.new_plane("Glass")
        bpy.context.scene.frame_start, bpy.context.scene.frame_end = 1, 60
        area = next(a for a in win.screen.areas if a.type == "VIEW_3D")
        with bpy.context.temp_override(window=win, area=area):
            r = bpy.ops.hydrobake.bake("INVOKE_DEFAULT", effect="testwave", object_name="Glass")
        if r != {"RUNNING_MODAL"}:
            fail(f"invoke returned {r}")
        state["phase"] = "baking"
        state["t0"] = now
        return 0.02
    job = jobs.ACTIVE.get(("Glass", "testwave"))
    if state["phase"] == "baking":
        if job is None:
            fail("the bake ended before Esc")
        if job.runner.state.done >= 3:
            win.event_simulate(type="ESC", value="PRESS")
            win.event_simulate(type="ESC", value="RELEASE")
            state["t_esc"], state["phase"] = now, "cancelling"
        elif now - state["t0"] > 30:
            fail("no progress")
        return 0.02
    if state["phase"] == "cancelling":
        if job is not None:  # the modal operator finalizes on its next timer tick
            if now - state["t_esc"] > 5:
                fail("Esc did not cancel")
            return 0.02
        took = now - state["t_esc"]
        gaps = [b - a for a, b in zip(state["ticks"], state["ticks"][1:])]
        settings = bpy.data.objects["Glass"].hydrobake_testwave
        cache = BakeCache(settings.bake_folder)
        done = cache.frames()
        print("ticks", [round(g, 3) for g in gaps], flush=True)
        print(f"UI cancel after {took:.3f}s, kept {len(done)} frames, worst UI gap "
              f"{max(gaps):.3f}s over {len(gaps)} ticks", flush=True)
        # Thresholds are loose for busy machines (software GL redraws take ~0.2 s under Xvfb;
        # with another Blender on each core, 1.03 s for the cancel); a bake blocking the main
        # thread would stall it for the whole bake (60 frames of 0.15 s: 9 s).
        ok = (took < 4.0 and max(gaps) < 4.0 and 3 <= len(done) < 60 and
              done == list(range(1, len(done) + 1)) and cache.verify() == [] and
              settings.is_baked and
              sorted(os.listdir(settings.bake_folder)) ==
              ["manifest.json"] + [f"{cache.read_manifest()['file_tag']}wave_{i:04d}.exr"
                                   for i in done])
        if not ok:
            fail(f"took={took} gaps={max(gaps)} done={done} files={os.listdir(settings.bake_folder)}")
        print("UI MODAL CANCEL OK", flush=True)
        os._exit(0)
    return None


in_blender.ui_steps(step)
