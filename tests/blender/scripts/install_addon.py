"""Installs the addon zip through Blender's own Install Add-on operator and enables it."""
import os
import sys

import addon_utils
import bpy

zip_path = sys.argv[sys.argv.index("--") + 1]
assert bpy.ops.preferences.addon_install(filepath=zip_path, overwrite=True) == {"FINISHED"}
installed = os.path.join(bpy.utils.user_resource("SCRIPTS", path="addons"), "hydrobake")
assert os.path.isfile(os.path.join(installed, "lib", "libhydrobake.so")), installed
assert bpy.ops.preferences.addon_enable(module="hydrobake") == {"FINISHED"}
loaded, enabled = addon_utils.check("hydrobake")
assert loaded and enabled, (loaded, enabled)
import hydrobake  # noqa: E402
assert os.path.dirname(hydrobake.__file__) == installed, hydrobake.__file__
assert hasattr(bpy.types.Scene, "hydrobake")
assert bpy.ops.preferences.addon_disable(module="hydrobake") == {"FINISHED"}
assert not hasattr(bpy.types.Scene, "hydrobake")  # unregisters cleanly
print("HYDROBAKE INSTALLED", installed)
