"""In the real Blender UI (under Xvfb): what an artist does while Bake runs modal, with snow,
rain and the fluid at 32 x 16 x 16.

1. Objects renamed while they bake (and a new object given the old name) get their own bake,
   recorded and wired on them, never on the newcomer; a second bake of the renamed object, or
   one of the newcomer into the same folder, is refused; the file saved elsewhere meanwhile
   (File > Save As) records the bake where it is.
2. A baked glass turned into a curve while it bakes: the wiring error is reported and the bake
   stays recorded (Free Bake can undo it), no exception escapes the modal operator.
3. Another file opened while snow bakes (Blender quit alike): reopening the file saved before
   the bake, the panel offers Resume for the bake it does not record, and Resume keeps the
   frames baked before.
4. The fluid cancelled with the panel's Cancel: frames kept, Resume offered, and it finishes.
5. Undo after a bake: the bake is one undo step, its record and wiring undone and redone
   together.
6. A baked pool deleted: its caustics leave the floor, and undo and redo agree. The snowy hat
   deleted keeps its wiring in its material; Remove Deleted Objects' Bakes takes it out, and
   undo brings it back, then the hat."""
import os
import time
import traceback

import bpy

import in_blender

in_blender.enable()
from hydrobake.blender import jobs  # noqa: E402
from hydrobake.core.bake.cache import BakeCache  # noqa: E402

tmp = in_blender.args()[0]


def fail(msg):
    print("UI TEST FAILED:", msg, flush=True)
    os._exit(1)


def check(ok, msg):
    if not ok:
        fail(msg)


def window_context():
    """The window, for what needs one (INVOKE_DEFAULT, undo). Nothing else runs in it while a
    bake does: Blender 3.4 looks an override's members up in a Python dict without taking the
    GIL whenever another thread holds it (BPY_context_member_get), and a bake's thread often
    does, so an operator run in an override then could crash Blender (pymalloc from two
    threads). The artist's own clicks carry no override."""
    win = bpy.context.window_manager.windows[0]
    area = next(a for a in win.screen.areas if a.type == "VIEW_3D")
    region = next(r for r in area.regions if r.type == "WINDOW")
    return bpy.context.temp_override(window=win, area=area, region=region)


def invoke(effect, name, **kw):
    """The Bake button (INVOKE_DEFAULT, modal); a refusal's report as a string."""
    with window_context():
        try:
            return bpy.ops.hydrobake.bake("INVOKE_DEFAULT", effect=effect, object_name=name,
                                          **kw)
        except RuntimeError as exc:
            return str(exc)


def buttons(obj, effect):
    """The operator buttons the effect's panel shows for ``obj``: [(operator, text)]."""
    log = in_blender.panel_calls(obj, effect)
    buttons.log = log
    return [(a[0], k.get("text")) for n, a, k in log if n == "operator" and
            a[0].startswith("hydrobake.") and a[0] != "hydrobake.apply_preset"]


def wait(cond, what, timeout=120):
    t0 = time.monotonic()
    while not cond():
        if time.monotonic() - t0 > timeout:
            fail(f"timed out waiting for {what}")
        yield 0.05


def done(name, effect):
    """Frames done by the bake begun on the object then called ``name``."""
    job = jobs.ACTIVE.get((name, effect))
    return job.runner.state.done if job else -1


def new_mesh(add, name, **kw):
    add(**kw)
    obj = bpy.context.view_layer.objects.active
    obj.name = obj.data.name = name
    return obj


def rain(obj, frames, cell):
    r = obj.hydrobake_rain
    r.enabled = True
    r.use_scene_range, r.frame_start, r.frame_end = False, frames[0], frames[1]
    r.rain.cell_size = cell
    return r


def scenario():
    bpy.ops.wm.save_as_mainfile(filepath=os.path.join(tmp, "a.blend"))
    cube = bpy.data.objects["Cube"]
    in_blender.snow(cube, (1, 60), 2000.0, 128)
    glass = new_mesh(bpy.ops.mesh.primitive_plane_add, "Glass", size=2, location=(4, 0, 0))
    rain(glass, (1, 40), 0.01)
    bpy.ops.wm.save_mainfile()

    # 1. Renamed while baking; the old name taken; the file saved elsewhere.
    check(invoke("snow", "Cube") == {"RUNNING_MODAL"}, "snow bake did not start")
    check(invoke("rain", "Glass") == {"RUNNING_MODAL"}, "rain bake did not start")
    yield from wait(lambda: done("Cube", "snow") >= 1 and done("Glass", "rain") >= 1, "frames")
    cube.name, glass.name = "Cube2", "Glass2"
    newcomer = new_mesh(bpy.ops.mesh.primitive_monkey_add, "Cube", location=(0, 5, 0))
    drawn = buttons(cube, "snow")
    check(("hydrobake.cancel_bake", "Cancel") in drawn,
          f"the renamed object's panel shows no running bake: {drawn}")
    progress = [a[0] if a else k.get("text") for n, a, k in buttons.log if n == "label"]
    check(("hydrobake.cancel_bake", "Cancel") not in buttons(newcomer, "snow"),
          "the newcomer's panel shows the renamed object's bake")
    check(any(p and p.startswith("Baking frame") and "left)" in p for p in progress),
          f"no progress with the time left: {progress}")
    check("already running" in str(invoke("snow", "Cube2")), "a second bake of Cube2 started")
    check("first called by this name" in str(invoke("snow", "Cube")),
          "the newcomer's bake into the running bake's folder started")
    os.makedirs(os.path.join(tmp, "sub"))
    bpy.ops.wm.save_as_mainfile(filepath=os.path.join(tmp, "sub", "b.blend"))
    yield from wait(lambda: not jobs.ACTIVE, "the bakes to end")
    for obj, effect in ((cube, "snow"), (glass, "rain")):
        s = jobs.settings_of(obj, effect)
        check(s.is_baked and s.get("baked_as") == obj.name,
              f"{obj.name}'s {effect} bake is not recorded on it")
        check(jobs.bake_state(obj, effect) == "COMPLETE",
              f"{obj.name}'s {effect} record does not find its bake: {s.bake_folder!r} "
              f"(file {bpy.data.filepath})")
        check(not any("baking" in k for k in s.keys()), f"{obj.name} keeps a baking mark")
    check(not newcomer.hydrobake_snow.is_baked and not newcomer.material_slots,
          f"the bake was wired onto the newcomer: {[m.name for m in newcomer.data.materials]}")
    print("PHASE 1 OK: renamed while baking", flush=True)

    # 2. The object changes so that wiring fails.
    pane = new_mesh(bpy.ops.mesh.primitive_plane_add, "Pane", size=2, location=(8, 0, 0))
    rain(pane, (1, 40), 0.01)
    check(invoke("rain", "Pane") == {"RUNNING_MODAL"}, "pane bake did not start")
    yield from wait(lambda: done("Pane", "rain") >= 1, "a pane frame")
    for o in bpy.context.view_layer.objects:
        o.select_set(o == pane)
    bpy.context.view_layer.objects.active = pane
    check(bpy.ops.object.convert(target="CURVE") == {"FINISHED"}, "convert")
    pane = bpy.data.objects["Pane"]
    yield from wait(lambda: not jobs.ACTIVE, "the pane's bake to end")
    s = pane.hydrobake_rain
    check(s.is_baked and s.get("baked_as") == "Pane" and not any("baking" in k for k in s.keys()),
          f"the pane's bake is half recorded: {dict(s.items())}")
    print("PHASE 2 OK: a wiring error is reported", flush=True)

    # 3. Another file opened while snow bakes; the file saved before it reopened.
    roof = new_mesh(bpy.ops.mesh.primitive_cube_add, "Roof", location=(0, -5, 0))
    in_blender.snow(roof, (1, 150), 2000.0, 128)
    bpy.ops.wm.save_as_mainfile(filepath=os.path.join(tmp, "c.blend"))
    check(invoke("snow", "Roof") == {"RUNNING_MODAL"}, "roof bake did not start")
    yield from wait(lambda: done("Roof", "snow") >= 3, "roof frames")
    bpy.ops.wm.read_homefile()
    check(not jobs.ACTIVE, "File > New left the bake running")
    yield 0.2
    bpy.ops.wm.open_mainfile(filepath=os.path.join(tmp, "c.blend"))
    yield 0.2
    roof = bpy.data.objects["Roof"]
    check(not roof.hydrobake_snow.is_baked, "the file saved before the bake records it?")
    offered = buttons(roof, "snow")
    check(("hydrobake.bake", "Resume") in offered, f"no Resume for the lost bake: {offered}")
    check(invoke("snow", "Roof", resume=True) == {"RUNNING_MODAL"}, "resume did not start")
    job = jobs.ACTIVE[("Roof", "snow")]
    yield from wait(lambda: not jobs.ACTIVE, "the resumed bake")
    check(job.runner.resumed_from is not None and job.runner.resumed_from >= 1 and
          jobs.bake_state(roof, "snow") == "COMPLETE",
          f"resume: from {job.runner.resumed_from}, {jobs.bake_state(roof, 'snow')}")
    print("PHASE 3 OK: resumed after another file was opened", flush=True)

    # 4. The fluid, cancelled with the panel's Cancel button, then resumed.
    domain, _fill, s = in_blender.dam_break((32, 16, 16), frames=(1, 24))
    check(invoke("fluid", "Domain") == {"RUNNING_MODAL"}, "fluid bake did not start")
    yield from wait(lambda: done("Domain", "fluid") >= 2, "fluid frames")
    check(bpy.ops.hydrobake.cancel_bake(effect="fluid", object_name="Domain") ==
          {"FINISHED"}, "Cancel")
    yield from wait(lambda: not jobs.ACTIVE, "the fluid's cancel", timeout=10)
    check(s.is_baked and jobs.bake_state(domain, "fluid") == "PARTIAL", "fluid not partial")
    # Resume starts at the latest checkpoint the cancel left. Which frame that is depends on
    # timing (checkpoints are skipped while they would cost over a tenth of the bake, and a
    # cancel inside a step cannot save the state the step was changing), so it is read back.
    cache = BakeCache(bpy.path.abspath(s.bake_folder))
    kept = cache.read_manifest()
    latest = max(int(f) for f in kept["checkpoints"])
    before = {f: v for f, v in kept["frames"].items() if int(f) <= latest}
    check(latest >= 1 and set(before) == {str(f) for f in range(1, latest + 1)},
          f"the cancelled fluid's checkpoints {sorted(kept['checkpoints'])}, frames "
          f"{sorted(kept['frames'], key=int)}")
    check(("hydrobake.bake", "Resume") in buttons(domain, "fluid"), "no Resume (fluid)")
    check(invoke("fluid", "Domain", resume=True) == {"RUNNING_MODAL"}, "fluid resume")
    job = jobs.ACTIVE[("Domain", "fluid")]
    yield from wait(lambda: not jobs.ACTIVE, "the fluid's resume")
    done_m = cache.read_manifest()
    check(job.runner.resumed_from == latest and jobs.bake_state(domain, "fluid") == "COMPLETE",
          f"fluid resume: from {job.runner.resumed_from}, latest checkpoint {latest}")
    check(all(done_m["frames"][f] == v for f, v in before.items()),
          "the resume re-baked frames it had kept")
    print("PHASE 4 OK: the fluid cancelled and resumed", flush=True)

    # 5. Ctrl+Z after a bake: an edit after it is undone alone; one more undoes the bake's
    # record and wiring together, and redo brings both back.
    hat = new_mesh(bpy.ops.mesh.primitive_cube_add, "Hat", location=(0, 9, 0))
    hat.data.materials.append(in_blender.node_material("Felt"))
    in_blender.snow(hat, (1, 8), 500.0, 32)
    bpy.ops.ed.undo_push(message="Hat")
    check(invoke("snow", "Hat") == {"RUNNING_MODAL"}, "hat bake did not start")
    yield from wait(lambda: not jobs.ACTIVE, "the hat's bake")
    yield 0.2

    def hat_state():
        obj = bpy.data.objects["Hat"]  # undo replaces the Python objects
        wired = any(n.get("hydrobake") for n in bpy.data.materials["Felt"].node_tree.nodes)
        return obj.hydrobake_snow.is_baked, wired
    check(hat_state() == (True, True), f"hat not baked: {hat_state()}")
    hat.location.x = 2.0
    bpy.ops.ed.undo_push(message="Move")
    with window_context():
        bpy.ops.ed.undo()
    check(bpy.data.objects["Hat"].location.x == 0.0, "the move was not undone")
    check(hat_state() == (True, True), f"undoing the move undid the bake: {hat_state()}")
    with window_context():
        bpy.ops.ed.undo()
    check(hat_state() == (False, False), f"undoing the bake: {hat_state()}")
    with window_context():
        bpy.ops.ed.redo()
    check(hat_state() == (True, True), f"redoing the bake: {hat_state()}")
    print("PHASE 5 OK: undo and redo after a bake", flush=True)

    # 6. A baked pool deleted (not freed): its caustics leave the floor; Ctrl+Z brings pool
    # and caustics back, Ctrl+Shift+Z deletes it again.
    floor = new_mesh(bpy.ops.mesh.primitive_plane_add, "Floor", size=4, location=(0, 14, -1))
    floor.data.materials.append(in_blender.node_material("Tiles"))
    pool = new_mesh(bpy.ops.mesh.primitive_plane_add, "Pool", size=2, location=(0, 14, 0))
    c = pool.hydrobake_caustics
    c.enabled, c.ground_object = True, floor
    c.use_scene_range, c.frame_start, c.frame_end = False, 1, 2
    c.water.width, c.map_resolution = 16, 32
    check(invoke("caustics", "Pool") == {"RUNNING_MODAL"}, "pool bake did not start")
    yield from wait(lambda: not jobs.ACTIVE, "the pool's bake")
    yield 0.2

    def floor_wired():
        return any(n.get("hydrobake") for n in bpy.data.materials["Tiles"].node_tree.nodes)
    check(floor_wired(), "the floor was not wired")
    for o in bpy.context.view_layer.objects:
        o.select_set(o.name == "Pool")
    check(bpy.ops.object.delete("EXEC_DEFAULT", True) == {"FINISHED"}, "delete")
    yield 0.3  # the UI's update after the delete
    check(not floor_wired() and "Pool" not in bpy.data.objects,
          "the deleted pool's caustics stayed on the floor")
    with window_context():
        bpy.ops.ed.undo()
    yield 0.3
    check("Pool" in bpy.data.objects and floor_wired(), "undo did not bring the pool back")
    with window_context():
        bpy.ops.ed.redo()
    yield 0.3
    check("Pool" not in bpy.data.objects and not floor_wired(), "redo: the caustics came back")
    def felt_wired():
        return any(n.get("hydrobake") for n in bpy.data.materials["Felt"].node_tree.nodes)
    for o in bpy.context.view_layer.objects:
        o.select_set(o.name == "Hat")
    check(bpy.ops.object.delete("EXEC_DEFAULT", True) == {"FINISHED"}, "delete the hat")
    yield 0.3
    check("Hat" not in bpy.data.objects and felt_wired(), "the hat's delete changed Felt")
    with window_context():
        check(bpy.ops.hydrobake.remove_deleted_bakes("EXEC_DEFAULT", True) == {"FINISHED"},
              "remove the deleted hat's bake")
    yield 0.3
    check(not felt_wired(), "Remove left the deleted hat's snow in Felt")
    with window_context():
        bpy.ops.ed.undo()
    yield 0.3
    check("Hat" not in bpy.data.objects and felt_wired(), "undoing Remove")
    with window_context():
        bpy.ops.ed.undo()
    yield 0.3
    check("Hat" in bpy.data.objects and felt_wired() and
          bpy.data.objects["Hat"].hydrobake_snow.is_baked, "undoing the hat's delete")
    print("PHASE 6 OK: a baked pool deleted, undone, redone; a deleted hat's bake removed, "
          "undone", flush=True)
    print("UI BAKE WHILE EDITING OK", flush=True)
    os._exit(0)


steps = scenario()


def tick():
    try:
        return next(steps)
    except StopIteration:
        return None
    except Exception:
        traceback.print_exc()
        os._exit(1)


bpy.app.timers.register(tick, first_interval=0.5, persistent=True)
