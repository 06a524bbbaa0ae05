"""Prints an effect setting of an object in the opened file: SETTING <value> BAKED <is_baked>."""
import bpy

import in_blender

in_blender.enable()
obj_name, effect, path = in_blender.args()[:3]
target = getattr(bpy.data.objects[obj_name], f"hydrobake_{effect}")
settings = target
for part in path.split("."):
    target = getattr(target, part)
value = tuple(target) if hasattr(target, "__len__") and not isinstance(target, str) else target
print("SETTING", repr(value), "BAKED", settings.is_baked)
