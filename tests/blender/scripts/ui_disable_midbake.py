"""In the real Blender UI: the addon disabled (Preferences) while a bake runs modal. The bake
stops, the frames it wrote stay whole, the status bar and progress let go; enabled again,
the panel's Resume finishes the bake as if it had never stopped."""
import os
import threading
import time

import addon_utils
import bpy

import in_blender
from in_blender import ui_fail as fail

in_blender.enable()
from hydrobake.blender import jobs  # noqa: E402
from hydrobake.core.bake import BakeCache  # noqa: E402

tmp = in_blender.args()[0]
state = {"phase": "start", "status": None}
_status_text_set = bpy.types.WorkSpace.status_text_set


def status_text_set(self, text):  # what the status bar shows (it has no getter)
    state["status"] = text
    return _status_text_set(self, text)


bpy.types.WorkSpace.status_text_set = status_text_set


def step():
    win = bpy.context.window_manager.windows[0]
    if state["phase"] == "start":
        bpy.ops.wm.save_as_mainfile(filepath=os.path.join(tmp, "ui.blend"))
        glass = in_blender.new_plane("Glass")
        uv = glass.data.uv_layers.new(name="UVMap")
        for loop, c in zip(uv.data, ((0, 0), (1, 0), (1, 1), (0, 1))):
            loop.uv = c
        s = glass.hydrobake_rain
        s.enabled, s.rain.cell_size = True, 0.004
        s.use_scene_range, s.frame_start, s.frame_end = False, 1, 400
        area = next(a for a in win.screen.areas if a.type == "VIEW_3D")
        with bpy.context.temp_override(window=win, area=area):
            r = bpy.ops.hydrobake.bake("INVOKE_DEFAULT", effect="rain", object_name="Glass")
        if r != {"RUNNING_MODAL"}:
            fail(f"invoke returned {r}")
        state.update(phase="baking", t0=time.monotonic())
        return 0.05
    if state["phase"] == "baking":
        job = jobs.ACTIVE.get(("Glass", "rain"))
        if job is None:
            fail("the bake ended before the addon was disabled")
        if job.runner.state.done < 3 or not state["status"]:
            if time.monotonic() - state["t0"] > 60:
                fail("no progress")
            return 0.05
        state["threads"] = threading.active_count()
        state["folder"] = job.folder
        assert bpy.ops.preferences.addon_disable(module="hydrobake") == {"FINISHED"}
        state["phase"] = "disabled"
        return 0.5  # a few of the window's ticks: nothing of the bake may fire in them
    if state["phase"] == "disabled":
        if jobs.ACTIVE:
            fail(f"bakes still active: {list(jobs.ACTIVE)}")
        if threading.active_count() >= state["threads"]:
            fail(f"the bake's thread still runs ({threading.enumerate()})")
        if hasattr(bpy.types.Object, "hydrobake_rain"):
            fail("the addon's properties are still registered")
        cache = BakeCache(state["folder"])
        done = cache.frames()
        files = sorted(os.listdir(state["folder"]))
        if not (3 <= len(done) < 400 and done == list(range(1, len(done) + 1)) and
                cache.verify() == [] and not [f for f in files if "tmp" in f]):
            fail(f"frames {done}, files {files}")
        if state["status"] is not None:
            fail(f"the status bar still shows {state['status']!r}")
        addon_utils.enable("hydrobake", default_set=True)
        glass = bpy.data.objects["Glass"]
        s = glass.hydrobake_rain
        if s.is_baked or jobs.unrecorded_bake(glass, "rain") is None:
            fail(f"is_baked {s.is_baked}; the panel does not offer Resume")
        s.frame_end = len(done) + 2  # the rest at a test's pace
        assert bpy.ops.hydrobake.bake(effect="rain", object_name="Glass", resume=True) == \
            {"FINISHED"}
        cache = BakeCache(s.bake_folder)
        if not (s.is_baked and cache.frames() == list(range(1, len(done) + 3)) and
                cache.verify() == []):
            fail(f"resumed: is_baked {s.is_baked} frames {cache.frames()}")
        print(f"UI DISABLE MIDBAKE OK kept {len(done)} frames", flush=True)
        os._exit(0)
    return None


in_blender.ui_steps(step)
