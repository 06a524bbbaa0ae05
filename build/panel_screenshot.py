"""The README's picture of an effect's panel: Blender's UI on a virtual display, the Physics tab
of a baked object of out/examples.blend (the main job's), with that effect's panel open.

    xvfb-run -a -s "-screen 0 520x1400x24" blender out/examples.blend \
        --python build/panel_screenshot.py -- docs/images Water caustics

Needs the addon installed (build/hydrobake-batch's habit: enabled here if it is not)."""
import os
import sys

import addon_utils
import bpy

out_dir, obj_name, effect = sys.argv[sys.argv.index("--") + 1:][:3]
if "hydrobake" not in bpy.context.preferences.addons:
    addon_utils.enable("hydrobake", default_set=False)
# The panels start closed; this one is registered again open, for the picture only.
panel = getattr(bpy.types, f"HYDROBAKE_PT_{effect}")
bpy.utils.unregister_class(panel)
panel.bl_options = set()
bpy.utils.register_class(panel)


def steps():
    """One step a timer tick: Blender draws the window between them."""
    win = bpy.context.window_manager.windows[0]
    area = max(win.screen.areas, key=lambda a: a.width * a.height)
    area.type = "PROPERTIES"
    win.scene = next(sc for sc in bpy.data.scenes if obj_name in sc.objects)
    yield 0.5
    obj = bpy.data.objects[obj_name]
    for o in bpy.context.view_layer.objects:
        o.select_set(o == obj)
    bpy.context.view_layer.objects.active = obj
    yield 0.5
    area.spaces[0].context = "PHYSICS"
    yield 1.0
    path = os.path.abspath(os.path.join(out_dir, f"panel_{effect}.png"))
    with bpy.context.temp_override(window=win, screen=win.screen, area=area):
        bpy.ops.screen.screenshot_area(filepath=path)
    print(f"panel_screenshot: {path}", flush=True)
    bpy.ops.wm.quit_blender()


it = steps()
bpy.app.timers.register(lambda: next(it, None), first_interval=2.0)
