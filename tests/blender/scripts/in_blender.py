"""Shared by the test scripts: enable the installed addon, read arguments."""
import faulthandler
import os
import sys
import traceback

import addon_utils
import bpy

# A crash prints every thread's Python stack, the crashing one marked "Current thread", before
# Blender's own handler (whose Python backtrace is that of whichever thread holds the GIL).
faulthandler.enable(all_threads=True)


def enable():
    addon_utils.enable("hydrobake", default_set=False, handle_error=_raise)
    import hydrobake
    return hydrobake


def _raise(exc):
    raise exc


def args():
    return sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []


def new_plane(name="Glass"):
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata([(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)], [], [(0, 1, 2, 3)])
    obj = bpy.data.objects.new(name, mesh)
    bpy.context.scene.collection.objects.link(obj)
    return obj


def uv_plane(name="Glass"):
    """new_plane with a UV map covering 0..1 (the rain's grid, snow's texture)."""
    obj = new_plane(name)
    obj.data.uv_layers.new(name="UVMap")
    for loop, uv in zip(obj.data.uv_layers[0].data, ((0, 0), (1, 0), (1, 1), (0, 1))):
        loop.uv = uv
    return obj


def liquid(location, resolution, cache_directory, ball_radius, ball_location):
    """A Mantaflow liquid domain "Tank" (a 2 m cube at ``location``, Mesh on, caching the
    scene's frames) and a ball of liquid in it, not baked yet: (domain, its domain settings,
    the ball's flow settings). bake_liquid() bakes it."""
    scene = bpy.context.scene
    bpy.ops.mesh.primitive_cube_add(size=2, location=location)
    dom = bpy.context.active_object
    dom.name = "Tank"
    mod = dom.modifiers.new("Fluid", "FLUID")
    mod.fluid_type = "DOMAIN"
    d = mod.domain_settings
    d.domain_type, d.resolution_max, d.use_mesh = "LIQUID", resolution, True
    d.cache_directory, d.cache_type = cache_directory, "ALL"
    d.cache_frame_start, d.cache_frame_end = scene.frame_start, scene.frame_end
    bpy.ops.mesh.primitive_uv_sphere_add(radius=ball_radius, location=ball_location)
    ball = bpy.context.active_object
    fm = ball.modifiers.new("Fluid", "FLUID")
    fm.fluid_type = "FLOW"
    fm.flow_settings.flow_type, fm.flow_settings.flow_behavior = "LIQUID", "GEOMETRY"
    return dom, d, fm.flow_settings


def bake_liquid(dom):
    """Bakes the liquid() scene with Blender's own operator and hides the ball."""
    with bpy.context.temp_override(object=dom, active_object=dom, scene=bpy.context.scene):
        assert bpy.ops.fluid.bake_all() == {"FINISHED"}
    for o in bpy.data.objects:
        if o != dom and any(m.type == "FLUID" for m in o.modifiers):
            o.hide_render = o.hide_viewport = True


def new_box(name, scale, location):
    """A unit cube scaled and placed (the fluid tests' domains and fills)."""
    import bmesh
    obj = new_plane(name)
    bm = bmesh.new()
    bmesh.ops.create_cube(bm, size=1.0)
    bm.to_mesh(obj.data)
    bm.free()
    obj.scale, obj.location = scale, location
    return obj


def dam_break(resolution, textures=2, frames=(1, 2), substeps=4):
    """The fluid tests' scene: a 1 x 0.5 x 0.5 m domain, a water column at its left end."""
    domain = new_box("Domain", (1.0, 0.5, 0.5), (0.5, 0.25, 0.25))
    fill = new_box("Column", (0.25, 0.45, 0.4), (0.15, 0.25, 0.21))
    s = domain.hydrobake_fluid
    s.enabled, s.fill_object = True, fill
    s.fluid.resolution, s.fluid.substeps, s.fluid.textures = resolution, substeps, textures
    s.use_scene_range, s.frame_start, s.frame_end = False, frames[0], frames[1]
    return domain, fill, s


def ring_drop(obstacles):
    """The obstacle tests' scene: a 0.6 m cube domain at 24 cells a side, a column of water
    dropped from its top over the collection ``obstacles``, frames 1-9."""
    domain = new_box("Domain", (0.6, 0.6, 0.6), (0.3, 0.3, 0.3))
    column = new_box("Column", (0.2, 0.2, 0.15), (0.3, 0.3, 0.48))
    f = domain.hydrobake_fluid
    f.enabled, f.fill_object, f.obstacles = True, column, obstacles
    f.fluid.resolution, f.fluid.substeps, f.fluid.textures = (24, 24, 24), 4, 2
    f.use_scene_range, f.frame_start, f.frame_end = False, 1, 9
    return domain


def water_under_hole(domain):
    """Bakes ring_drop's domain, frees it, and gives the most baked density, frames 6-9, in
    the voxels under the hole of a ring at its middle (x and y 0.27-0.33, z 0.1-0.18)."""
    import glob
    import os
    from hydrobake.blender import jobs
    from hydrobake.core import vdb
    assert bpy.ops.hydrobake.bake(effect="fluid", object_name=domain.name) == {"FINISHED"}
    folder = bpy.path.abspath(jobs.folder_of(domain, "fluid"))
    cell, most = 0.6 / 24, 0.0
    for frame in range(6, 10):
        d = vdb.read(glob.glob(os.path.join(folder, f"*fluid_{frame:04d}.vdb"))[0])["density"]
        acc = d.getConstAccessor()
        for x in (0.27, 0.3, 0.33):
            for y in (0.27, 0.3, 0.33):
                for z in (0.1, 0.14, 0.18):
                    most = max(most, acc.getValue(tuple(int(v / cell) for v in (x, y, z))))
    assert bpy.ops.hydrobake.free_bake(effect="fluid", object_name=domain.name) == {"FINISHED"}
    return most


def effect_inputs(obj, effect):
    """The inputs a bake of ``effect`` on ``obj`` would take (its Job made, then let go)."""
    from hydrobake.blender import jobs
    job = jobs.Job(bpy.context, obj, effect)
    try:
        return job.runner.effect.inputs
    finally:
        job.runner.effect.close()
        del getattr(obj, f"hydrobake_{effect}")[jobs.BAKING]


def fluid_inputs(domain):
    """The inputs a fluid bake of ``domain`` would take."""
    return effect_inputs(domain, "fluid")


def inputs_refused(obj, effect, text):
    """Asserts that a bake of ``effect`` on ``obj`` is refused as it prepares its inputs,
    with ``text`` in the error."""
    try:
        effect_inputs(obj, effect)
    except Exception as exc:  # the job refuses in its prepare
        assert text in str(exc), str(exc)
        return
    raise AssertionError(f"not refused: {text}")


def baked_glass(blend):
    """Saves the session as ``blend`` (empty_file) and bakes one frame of rain on a plane
    "Glass" with a coarse rain grid; returns the plane's rain settings."""
    empty_file(blend)
    s = rain_once(uv_plane("Glass"))
    assert bpy.ops.hydrobake.bake(effect="rain", object_name="Glass") == {"FINISHED"}
    return s


def rain_once(obj):
    """The object's rain settings for a small test bake: enabled, frame 1 alone, a coarse
    grid."""
    s = obj.hydrobake_rain
    s.enabled, s.use_scene_range, s.frame_start, s.frame_end = True, False, 1, 1
    s.rain.cell_size = 0.05
    return s


def reopen():
    """Save, then open the file again, as the artist's reopen does."""
    bpy.ops.wm.save_mainfile()
    bpy.ops.wm.open_mainfile(filepath=bpy.data.filepath)


def snow(obj, frames, density, texture=64):
    """The object's snow settings for a small test bake: enabled, the frame range, the
    Flake Density (flakes per m³ of the Auto Volume; a 2 m cube's is about 100 m³ in the
    default wind) and square textures of ``texture`` texels."""
    s = obj.hydrobake_snow
    s.enabled = True
    s.use_scene_range, s.frame_start, s.frame_end = False, frames[0], frames[1]
    s.flake_density = density
    s.snow.texture_width = s.snow.texture_height = texture
    return s


def select_alone(obj, also=None):
    """The object selected alone and active, as the artist's click leaves it (the operators
    of Duplicate, Delete and Remove Unused Slots read the view layer, not the context); with
    ``also`` selected too (Shift+click before: Join, Link Materials)."""
    for o in bpy.context.view_layer.objects:
        o.select_set(o in (obj, also))
    bpy.context.view_layer.objects.active = obj


def duplicate(obj, linked=False):
    """Shift+D on ``obj`` alone, as the artist does it (the copy keeps every property, a bake
    record too), or Alt+D (``linked``: the copy shares the mesh); returns the copy."""
    bpy.context.view_layer.update()  # objects just linked are not the view layer's before
    select_alone(obj)
    assert bpy.ops.object.duplicate(linked=linked) == {"FINISHED"}
    return bpy.context.view_layer.objects.active


def empty_file(name):
    """Saves the session as ``name`` in the test's folder (bakes go next to it) and removes
    every object (the factory Cube, camera and light); returns the folder."""
    import os
    tmp = args()[0]
    bpy.ops.wm.save_as_mainfile(filepath=os.path.join(tmp, name))
    for o in list(bpy.data.objects):
        bpy.data.objects.remove(o)
    return tmp


def node_material(name):
    """A new material with its nodes on (a Principled BSDF)."""
    mat = bpy.data.materials.new(name)
    mat.use_nodes = True
    return mat


class Layout:
    """Records what a panel draws: every call as (name, args, kwargs) in ``log``."""

    def __init__(self, log):
        self.__dict__["log"] = log

    def __getattr__(self, name):
        def call(*args, **kwargs):
            self.log.append((name, args, kwargs))
            return Layout(self.log)
        return call


def panel_calls(obj, effect):
    """What the effect's panel draws for ``obj``: [(name, args, kwargs)]."""
    from hydrobake.blender import effects, ui
    log = []

    class Context:
        object, scene, view_layer = obj, bpy.context.scene, bpy.context.view_layer
    ui.draw_effect(Layout(log), Context, effects.get(effect))
    return log


def ui_fail(msg):
    """Ends a UI test as failed (its window would stay open otherwise)."""
    print("UI TEST FAILED:", msg, flush=True)
    os._exit(1)


def ui_steps(step):
    """Runs ``step()`` on a timer in the UI, again after each interval it returns, until it
    returns None; an exception fails the test."""
    def tick():
        try:
            return step()
        except Exception:
            traceback.print_exc()
            os._exit(1)
    bpy.app.timers.register(tick, first_interval=0.5)


# Blender 3.4 keeps an object's own materials past its slots when a slot goes, and copies them
# with the object (Shift+D); no ID user counts them, so a material removed from the file leaves
# them pointing at freed memory, which a slot added later shows (a segfault, or not, as the
# memory falls). These read that list from the Object itself, to find such a pointer at once.
_MAT_FIELD = []


def _word(address, offset=0):
    import ctypes
    return ctypes.c_uint64.from_address(address + offset).value


def _mat_field():
    """The offset in the Object struct of ``mat`` (Material **), followed by ``matbits`` and
    the ints ``totcol`` and ``actcol``: found once on a probe object with three own materials
    and checked against their addresses, so a different struct layout fails, not misreads."""
    if _MAT_FIELD:
        return _MAT_FIELD[0]
    import ctypes
    mesh = bpy.data.meshes.new("HBK probe")
    obj = bpy.data.objects.new("HBK probe", mesh)
    mats = [bpy.data.materials.new(f"HBK probe {i}") for i in range(3)]
    try:
        for m in mats:
            mesh.materials.append(None)
        for s, m in zip(obj.material_slots, mats):
            s.link = "OBJECT"
            s.material = m
        obj.active_material_index = 1
        base, want = obj.as_pointer(), [m.as_pointer() for m in mats]
        for off in range(0, 4096, 8):
            ints = (ctypes.c_int * 2).from_address(base + off + 16)
            p = _word(base, off)
            if (ints[0], ints[1]) == (3, 2) and p and [_word(p, 8 * i) for i in range(3)] == want:
                _MAT_FIELD.append(off)
                return off
        raise AssertionError("no Object.mat found: the struct layout is not Blender 3.4's")
    finally:
        bpy.data.objects.remove(obj)
        bpy.data.meshes.remove(mesh)
        for m in mats:
            bpy.data.materials.remove(m)


def dangling_materials(but=()):
    """Each object whose own-material list (its slots' and past them, as far as its block
    goes) holds a material no longer in the file, at an address not in ``but``:
    {name: [(index, slots)]}. The block's length is the allocator's header just before it
    (guardedalloc, lock-free)."""
    import ctypes
    off = _mat_field()
    live = {m.as_pointer() for m in bpy.data.materials} | set(but) | {0}
    found = {}
    for obj in bpy.data.objects:
        if obj.type != "MESH":
            continue
        base = obj.as_pointer()
        p = _word(base, off)
        if not p:
            continue
        slots = ctypes.c_int.from_address(base + off + 16).value
        size = _word(p, -8) & ~3
        assert size % 8 == 0 and slots * 8 <= size <= 1 << 16, (obj.name, slots, size)
        bad = [i for i in range(size // 8) if _word(p, 8 * i) not in live]
        if bad:
            found[obj.name] = [(i, slots) for i in bad]
    return found
