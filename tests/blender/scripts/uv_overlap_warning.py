"""Snow and rain bake into the object's UVs, so faces sharing UV space share the result. A
layout that overlaps (a Mirror modifier's copy, stacked islands) is baked but warned of,
naming the share and the UV map; a clean layout, and snow's BOX mode (which makes its own
projection), give no warning. Then through the operator, whose report the test reads."""
import bpy

import in_blender

in_blender.enable()
from hydrobake.blender import jobs  # noqa: E402

in_blender.empty_file("overlap.blend")


def plane(name, mirrored):
    obj = in_blender.new_plane(name)
    obj.data.uv_layers.new(name="Unwrap")
    for loop, uv in zip(obj.data.uv_layers[0].data, ((0, 0), (1, 0), (1, 1), (0, 1))):
        loop.uv = uv
    if mirrored:  # its copy across x takes the same UVs
        obj.location.x = 5.0
        obj.modifiers.new("Mirror", "MIRROR").mirror_offset_u = 0.0
    return obj


def warnings_of(obj, effect):
    job = jobs.Job(bpy.context, obj, effect)
    job.runner.effect.close()
    return job.warnings


clean, mirrored = plane("Clean", False), plane("Mirrored", True)
for obj in (clean, mirrored):
    in_blender.snow(obj, (1, 1), 10.0, 16)
    r = obj.hydrobake_rain
    r.enabled, r.use_scene_range, r.frame_start, r.frame_end = True, False, 1, 1
    r.rain.cell_size = 0.05
for effect in ("snow", "rain"):
    assert warnings_of(clean, effect) == [], (effect, warnings_of(clean, effect))
    got = warnings_of(mirrored, effect)
    assert len(got) == 1 and got[0].startswith(
        "Mirrored: 100% of UV map 'Unwrap' is shared by two or more faces"), (effect, got)
    print(effect, got[0])
mirrored.hydrobake_snow.snow.contact_mode = "BOX"
assert warnings_of(mirrored, "snow") == []
mirrored.hydrobake_snow.snow.contact_mode = "TRIANGLES"
assert bpy.ops.hydrobake.bake(effect="snow", object_name="Mirrored") == {"FINISHED"}
print("UV OVERLAP WARNING OK")
