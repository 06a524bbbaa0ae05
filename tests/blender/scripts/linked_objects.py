"""A linked object and a library override keep their bake record in the library file: Bake,
Free Bake and presets refuse them by name (a bake recorded here was lost on the next save,
and a free could have removed the library's files), the panel says where to bake instead,
and the command line leaves them out unless named. An object made local alone is refused
while the mesh or material its bake would wire is still linked."""
import contextlib
import hashlib
import io
import os

import bpy

import in_blender

in_blender.enable()
from hydrobake.blender import cli, jobs  # noqa: E402

tmp = in_blender.args()[0]
s = in_blender.baked_glass("lib.blend")
s.enabled = True
bpy.ops.wm.save_mainfile()
lib_folder = s.bake_folder


def files(folder):
    return {n: hashlib.sha256(open(os.path.join(folder, n), "rb").read()).hexdigest()
            for n in sorted(os.listdir(folder))}


kept = files(lib_folder)
assert "manifest.json" in kept, kept

bpy.ops.wm.read_homefile(use_empty=True)
shot = os.path.join(tmp, "shot.blend")
bpy.ops.wm.save_as_mainfile(filepath=shot)
with bpy.data.libraries.load(os.path.join(tmp, "lib.blend"), link=True) as (src, dst):
    dst.objects = ["Glass"]
glass = dst.objects[0]
bpy.context.scene.collection.objects.link(glass)
assert glass.library is not None and glass.hydrobake_rain.is_baked


def refused(op, start, **kw):
    try:
        op(effect="rain", object_name="Glass", **kw)
    except RuntimeError as exc:
        assert start in str(exc) and "Make Local" in str(exc), exc
        return
    raise AssertionError(f"{op.idname()} took a linked object")


def panel(obj):
    calls = in_blender.panel_calls(obj, "rain")
    return ([k.get("text") for n, a, k in calls if n == "label"],
            [a[0] for n, a, k in calls if n == "operator"],
            {k.get("icon") for n, a, k in calls if n == "label" and k.get("icon")})


def unchanged():
    assert files(lib_folder) == kept, "the library's bake was touched"
    assert not os.path.exists(os.path.join(tmp, "hydrobake_cache", "shot")), \
        os.listdir(os.path.join(tmp, "hydrobake_cache", "shot"))


linked = f"Glass is linked from {glass.library.filepath}"
refused(bpy.ops.hydrobake.bake, linked)
refused(bpy.ops.hydrobake.bake, linked, resume=True)
refused(bpy.ops.hydrobake.free_bake, linked)
refused(bpy.ops.hydrobake.apply_preset, linked, preset=next(iter(
    __import__("hydrobake.blender.effects", fromlist=["get"]).get("rain").presets)))
unchanged()
said, buttons, icons = panel(glass)
assert "Linked from lib.blend: bake it there, or Make Local" in said, said
assert not {"hydrobake.bake", "hydrobake.free_bake"} & set(buttons), buttons
icon_names = bpy.types.UILayout.bl_rna.functions["label"].parameters["icon"].enum_items.keys()
assert icons <= set(icon_names), icons - set(icon_names)

# The command line: left out of a whole-file run (said on stderr), refused when named.
err = io.StringIO()
with contextlib.redirect_stderr(err):
    assert cli.targets() == []
assert f"hydrobake: Glass/rain skipped: {linked}" in err.getvalue(), err.getvalue()
assert cli.targets(["Glass"]) == [(glass, "rain")]
try:
    cli._bake(cli.parser().parse_args(["bake"]), False, cli.Interrupts())
    raise AssertionError("a whole-file bake of linked objects alone went on")
except KeyError as exc:
    assert exc.args[0].startswith("nothing to bake: no object of this file (those of linked "
                                  "objects are baked in their libraries)"), exc
out = io.StringIO()
with contextlib.redirect_stdout(out):
    cli.list_(None)
assert f"Glass/rain: enabled=True baked=True folder={lib_folder} " \
    f"library={glass.library.filepath}\n" in out.getvalue(), out.getvalue()
try:
    jobs.free(bpy.context, glass, "rain")
    raise AssertionError("freed a linked object's bake")
except ValueError as exc:
    assert str(exc).startswith(linked), exc
unchanged()

# A library override: its Hydrobake settings are the library's at every open.
over = glass.override_create(remap_local_usages=True)
assert over.library is None and over.override_library is not None
refused(bpy.ops.hydrobake.bake, "Glass is a library override")
refused(bpy.ops.hydrobake.free_bake, "Glass is a library override")
unchanged()
said, buttons, icons = panel(over)
assert "Library override: bake it in its library file, or Make Local" in said, said
assert not {"hydrobake.bake", "hydrobake.free_bake"} & set(buttons), buttons
assert icons <= set(icon_names), icons - set(icon_names)

# Made local alone, the object keeps the library's mesh and material, which the wiring would
# change: refused, naming each, until they are local too; then it bakes here.
bpy.ops.wm.read_homefile(use_empty=True)
bpy.ops.wm.save_as_mainfile(filepath=shot)
with bpy.data.libraries.load(os.path.join(tmp, "lib.blend"), link=True) as (src, dst):
    dst.objects = ["Glass"]
bpy.context.scene.collection.objects.link(dst.objects[0])
own = dst.objects[0].make_local()
assert own.library is None and own.data.library is not None
jobs.forget(own, "rain")  # (the library's record, copied: its bake is not this file's)
for part, make_local in ((f"Glass's mesh is linked from {own.data.library.filepath}",
                          lambda: own.data.make_local()),
                         ("Glass's material 'HBK_Glass_glass' is linked from",
                          lambda: own.material_slots[0].material.make_local())):
    said, buttons, icons = panel(own)
    assert any(x.startswith(part) for x in said) and "hydrobake.bake" in buttons, said
    assert icons <= set(icon_names), icons - set(icon_names)
    refused(bpy.ops.hydrobake.bake, part)
    unchanged()
    make_local()
assert bpy.ops.hydrobake.bake(effect="rain", object_name="Glass") == {"FINISHED"}
assert own.hydrobake_rain.bake_folder.startswith(os.path.join(tmp, "hydrobake_cache", "shot"))
bpy.ops.wm.save_mainfile()
assert files(lib_folder) == kept
bpy.ops.wm.open_mainfile(filepath=shot)
said, buttons, icons = panel(bpy.data.objects["Glass"])
assert bpy.data.objects["Glass"].hydrobake_rain.is_baked and "hydrobake.free_bake" in buttons

# In the library file itself the object is its own: freed and baked there.
bpy.ops.wm.open_mainfile(filepath=os.path.join(tmp, "lib.blend"))
assert bpy.ops.hydrobake.free_bake(effect="rain", object_name="Glass") == {"FINISHED"}
assert not os.path.exists(os.path.join(lib_folder, "manifest.json"))
assert bpy.ops.hydrobake.bake(effect="rain", object_name="Glass") == {"FINISHED"}
assert files(lib_folder) == kept, "baked again, the same bytes"
print("LINKED OBJECTS OK")
