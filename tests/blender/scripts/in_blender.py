"""Shared by the test scripts: enable the installed addon, read arguments."""
import sys

import addon_utils
import bpy


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
