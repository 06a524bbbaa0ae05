"""Where a bake goes: ``<cache folder>/<blend name>/<object>_<effect>/``, so bakes of different
files, objects and effects never mix."""
import os

import bpy


class CacheFolderError(ValueError):
    pass


def bake_folder(obj, effect_name, settings, override=None):
    """Absolute folder of this object's bake of ``effect_name``.

    ``override`` (command line) replaces the cache folder setting. A relative ('//') cache
    folder needs a saved .blend: an unsaved file raises CacheFolderError with the fix."""
    base = override or settings.cache_dir or "//hydrobake_cache/"
    blend = bpy.data.filepath
    if base.startswith("//") and not blend:
        raise CacheFolderError(
            "Save the .blend file first: the cache folder "
            f"'{base}' is relative to it (or set an absolute Cache Folder)")
    root = bpy.path.abspath(base)
    stem = os.path.splitext(os.path.basename(blend))[0] if blend else "untitled"
    leaf = f"{bpy.path.clean_name(obj.name)}_{effect_name}"
    return os.path.normpath(os.path.join(root, bpy.path.clean_name(stem), leaf))
