"""In the real Blender UI (under Xvfb, events simulated): Capture Paint from the surface's
panel asks for the texture and source in a dialog, and Return captures the stroke."""
import os
import time

import bpy
import numpy as np

import in_blender
from in_blender import ui_fail as fail

in_blender.enable()
tmp = in_blender.args()[0]
state = {"phase": "start"}


def step():
    win = bpy.context.window_manager.windows[0]
    if state["phase"] == "start":
        bpy.ops.wm.save_as_mainfile(filepath=os.path.join(tmp, "ui_capture.blend"))
        in_blender.dam_break((16, 8, 8))
        if bpy.ops.hydrobake.bake(effect="fluid", object_name="Domain") != {"FINISHED"}:
            fail("bake")
        bpy.context.scene.frame_set(2)
        surf = bpy.data.objects["HBK_Domain_surface"]
        surf.data.vertices.foreach_set("select", np.ones(len(surf.data.vertices), bool))
        bpy.context.view_layer.objects.active = surf
        area = next(a for a in win.screen.areas if a.type == "VIEW_3D")
        with bpy.context.temp_override(window=win, area=area, object=surf):
            r = bpy.ops.hydrobake.fluid_capture_paint("INVOKE_DEFAULT")
        if r != {"RUNNING_MODAL"}:
            fail(f"invoke returned {r}, not a dialog")
        if bpy.data.objects.get("HBK_Domain_paint_2") is not None:
            fail("captured before the dialog was confirmed")
        state["phase"], state["t0"] = "dialog", time.monotonic()
        return 0.3
    if state["phase"] == "dialog":
        win.event_simulate(type="RET", value="PRESS")
        win.event_simulate(type="RET", value="RELEASE")
        state["phase"] = "confirmed"
        return 0.3
    stroke = bpy.data.objects.get("HBK_Domain_paint_2")
    if stroke is None:
        if time.monotonic() - state["t0"] > 10:
            fail("Return did not capture")
        return 0.2
    p = stroke.hydrobake_fluid_paint
    if not (p.enabled and p.texture == 1 and p.frame == 2 and len(stroke.data.vertices) > 0):
        fail(f"stroke {p.enabled} {p.texture} {p.frame} {len(stroke.data.vertices)}")
    print("UI FLUID CAPTURE OK", flush=True)
    os._exit(0)


in_blender.ui_steps(step)
