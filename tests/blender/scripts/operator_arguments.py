"""What a script passes the operators that names nothing they take is refused, naming the
argument and what it takes, before anything is touched: an effect the addon does not have
(Free used to report an unwiring error, Cancel nothing at all, Apply Preset a missing preset),
an object that cannot have the effect, a preset the effect does not have. Found by a fuzzer of
the operators' arguments."""
import bpy

import in_blender

in_blender.enable()

s = in_blender.baked_glass("arguments.blend")
cam = bpy.data.objects.new("Cam", bpy.data.cameras.new("Cam"))
bpy.context.scene.collection.objects.link(cam)


def refused(op, **kw):
    try:
        op(**kw)
    except RuntimeError as exc:
        assert "Traceback" not in str(exc), exc
        return str(exc)
    raise AssertionError(f"{op} {kw} was not refused")


known = "must be one of caustics, fluid, rain, snow"
for op in (bpy.ops.hydrobake.bake, bpy.ops.hydrobake.free_bake, bpy.ops.hydrobake.cancel_bake,
           bpy.ops.hydrobake.apply_preset):
    for effect in ("nope", "", "RAIN"):
        msg = refused(op, effect=effect, object_name="Glass")
        assert f"effect = {effect!r}: {known}" in msg, (op, effect, msg)
assert s.is_baked and s.bake_folder  # untouched
msg = refused(bpy.ops.hydrobake.bake, effect="caustics", object_name="Cam")
assert "Cam cannot have the caustics effect (a camera)" in msg, msg
assert bpy.ops.hydrobake.free_bake(effect="rain", object_name="Glass") == {"FINISHED"}
msg = refused(bpy.ops.hydrobake.apply_preset, effect="rain", object_name="Glass",
              preset="Calm Pool")
assert "preset = 'Calm Pool': not a preset of rain (" in msg and "Downpour, Drizzle" in msg, msg
print("OPERATOR ARGUMENTS OK")
