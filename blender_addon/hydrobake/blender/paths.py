"""Where a bake goes: ``<cache folder>/<blend name>/<object>_<effect>/``, so bakes of different
files, objects and effects never mix."""
import hashlib
import os

import bpy


class CacheFolderError(ValueError):
    pass


def folder_name(name):
    """``name`` as a folder name, one folder per name: bpy.path.clean_name's where that leaves
    the name as it is, else the cleaned name and the first 6 hex digits of the SHA-1 of the
    raw one. clean_name alone maps "Pool.A" and "Pool_A" (or "Pool A") to one folder, and
    the second bake of the two would replace the first."""
    clean = bpy.path.clean_name(name)
    if clean == name:
        return clean
    return f"{clean}_{hashlib.sha1(name.encode('utf-8')).hexdigest()[:6]}"


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
    leaf = f"{folder_name(obj.name)}_{effect_name}"
    return os.path.normpath(os.path.join(root, folder_name(stem), leaf))


def stored(folder, settings, override=None):
    """How the file records a bake folder: relative to the .blend ('//...') when the cache
    folder setting is, so a project moved or opened elsewhere (a farm's mount) with its
    bakes still finds them; else absolute, as the artist set it."""
    base = override or settings.cache_dir or "//hydrobake_cache/"
    return bpy.path.relpath(folder) if base.startswith("//") and bpy.data.filepath else folder


def relink(folder, recorded):
    """Records the paths a bake's wiring gave its data (absolute, under ``folder``) the way
    ``recorded`` is: relative ones stay relative."""
    if recorded != folder:
        make_relative(folder)


def make_relative(root):
    """Every path under the folder ``root`` the file records, relative to the .blend: images,
    volumes, baked mesh sequences and bake folders (a farm's wiring step; Blender's own
    'Make Paths Relative' would change the artist's other paths too). A path on another
    drive (Windows) stays absolute."""
    from .bridge import frame_meshes
    top = os.path.normcase(os.path.join(os.path.abspath(bpy.path.abspath(root)), ""))

    def rel(path):
        full = os.path.abspath(bpy.path.abspath(path))
        if not path or not os.path.normcase(os.path.join(full, "")).startswith(top):
            return path
        try:
            return bpy.path.relpath(full)
        except ValueError:
            return path

    for block in (*bpy.data.images, *bpy.data.volumes):
        if block.library is None and rel(block.filepath) != block.filepath:
            block.filepath = rel(block.filepath)  # set only if changed: setting reloads
    for obj in bpy.data.objects:
        if obj.library is not None:
            continue
        if frame_meshes.PROP in obj:
            kind, where, stream = obj[frame_meshes.PROP].split("|", 2)
            obj[frame_meshes.PROP] = f"{kind}|{rel(where)}|{stream}"
        for key in obj.keys():  # the effects' settings: their bake folder as stored
            group = obj[key]
            folder = group.get("bake_folder") if key.startswith("hydrobake_") and hasattr(
                group, "get") else None
            if isinstance(folder, str):
                group["bake_folder"] = rel(folder)
