"""Where a bake goes: ``<cache folder>/<blend name>/<object>_<effect>/``, so bakes of different
files, objects and effects never mix."""
import hashlib
import os

import bpy

from ..core.bake.cache import MANIFEST


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


def file_tag(folder):
    """What begins the names of a bake's files in ``folder`` (``<blend>/<object>_<effect>``):
    ``shot_Car_snow_``. Blender's Unpack into the current folder writes each packed image to
    ``//textures/<its file name>`` and each volume to ``//volumes/...``; with one name for
    every bake, the second object's bake would take the first's file, or replace it."""
    parent, leaf = os.path.split(os.path.normpath(folder))
    return f"{os.path.basename(parent)}_{leaf}_".lstrip(".")  # (a dot would hide them)


def stored(folder, settings, override=None):
    """How the file records a bake folder: relative to the .blend ('//...') when the cache
    folder setting is, so a project moved or opened elsewhere (a farm's mount) with its
    bakes still finds them; else absolute, as the artist set it."""
    base = override or settings.cache_dir or "//hydrobake_cache/"
    return bpy.path.relpath(folder) if base.startswith("//") and bpy.data.filepath else folder


BAKE_BASE = "bake_base"  # beside an effect's bake_folder: the folder it is relative to


def here():
    """The .blend's folder, which '//' paths are relative to ('' for an unsaved file)."""
    return os.path.dirname(os.path.abspath(bpy.data.filepath)) if bpy.data.filepath else ""


def _inside(path, folders):
    """Whether the absolute ``path`` is in one of ``folders`` (absolute), or is one."""
    key = os.path.join(os.path.normcase(os.path.abspath(path)), "")
    return any(key.startswith(os.path.join(os.path.normcase(os.path.abspath(f)), ""))
               for f in folders)


def resolve(raw, base=None, library=None):
    """A folder or file the addon recorded, absolute. A relative ('//') one is taken from the
    .blend's folder, else from ``base``, the folder the .blend was in when it was recorded,
    where it exists only there: Blender rebases its own relative paths (images, volumes) when
    a file is saved into another folder or appended into another file, not an addon's
    strings, so after a Save As a bake is where ``base`` says until the next save rebases it
    (before_save). A project moved with its bakes finds them beside the .blend, as before.
    A record of a linked object (``library``) is relative to its library's file."""
    full = os.path.normpath(bpy.path.abspath(raw, library=library))
    if base and raw.startswith("//") and not os.path.exists(full):
        there = os.path.normpath(os.path.join(base, raw[2:]))
        if os.path.exists(there):
            return there
    return full


def record(group, key, value, base_key, folder=None):
    """Sets the record ``group[key]`` of a folder (``folder`` within ``value``, else all of it)
    and, for a relative one, the folder it is relative to."""
    group[key] = value
    if (folder or value).startswith("//") and here():
        group[base_key] = here()
    else:
        group.pop(base_key, None)


def _records(obj):
    """The paths ``obj`` records, as (group, key, base key, path, rebuild): the effects' bake
    folders, the fluid's voxel textures and a baked mesh sequence's folder (the middle of
    "kind|folder|stream"); rebuild(path) is the record's value for another path."""
    from .bridge import frame_meshes

    def same(path):
        return path
    for key in obj.keys():  # the effects' settings
        group = obj[key]
        if not key.startswith("hydrobake_") or not hasattr(group, "get"):
            continue
        if isinstance(group.get("bake_folder"), str):
            yield group, "bake_folder", BAKE_BASE, group["bake_folder"], same
        for sample in group.get("samples", ()):
            if isinstance(sample.get("voxel_file"), str):
                yield sample, "voxel_file", "voxel_file_base", sample["voxel_file"], same
    if isinstance(obj.get(frame_meshes.PROP), str):
        kind, folder, stream = obj[frame_meshes.PROP].split("|", 2)
        yield obj, frame_meshes.PROP, frame_meshes.PROP_BASE, folder, \
            lambda p: f"{kind}|{p}|{stream}"


_saving_from = []  # the .blend's folder when the save in progress began
_shown_before = []  # (block, the file it showed) of the bakes' data when the save began
DATA_BASE = "hydrobake_base"  # on a bake's image or volume: the folder its '//' path is from


def _in_bake_folder(path):
    """Whether the file ``path`` lies in a bake folder (one with a manifest)."""
    return os.path.isfile(os.path.join(os.path.dirname(path), MANIFEST))


def _bake_data():
    """The file's own images and volumes whose relative paths lead into a bake folder."""
    for block in (*bpy.data.images, *bpy.data.volumes):
        if block.library is None and block.filepath.startswith("//") and \
                _in_bake_folder(bpy.path.abspath(block.filepath)):
            yield block


def before_save():
    """save_pre: every relative folder the addon recorded becomes relative to the .blend's
    folder now, found where resolve finds it, with that folder as its base. Blender tells a
    save_pre handler nothing of where the file goes: a Save As writes the old folder as the
    base, and the saved file's bakes are found through it when it is opened."""
    _saving_from[:] = [here()]

    def found(folder, base):  # a path missing for now (a drive not mounted) keeps its base
        full = resolve(folder, base)
        return full if os.path.exists(full) else None
    _rebase(found)
    # A bake's data records its base too: a deleted object's bake, still shown, has no
    # record left to give repoint_data a base.
    _shown_before.clear()
    for block in _bake_data():
        if block.get(DATA_BASE) != here():
            block[DATA_BASE] = here()
        _shown_before.append((block, os.path.normpath(bpy.path.abspath(block.filepath))))


def after_save():
    """save_post: after a Save As into another folder the session's records follow, from the
    folder the file was in, as Blender's own relative paths did in the save (a Save Copy
    leaves the session's file where it was)."""
    old = _saving_from[0] if _saving_from else ""
    _saving_from.clear()
    shown, _shown_before[:] = list(_shown_before), []
    if old and here() and os.path.normcase(old) != os.path.normcase(here()):
        _rebase(lambda folder, _base: os.path.normpath(os.path.join(old, folder[2:])))
        # With Remap Relative off a bake's relative path can lead, from the new folder, to
        # another bake of the same name (an older version of the shot saved there): it
        # keeps showing the file it showed (monkey --more --elsewhere --relations 204).
        for block, full in shown:
            if os.path.normpath(bpy.path.abspath(block.filepath)) != full and \
                    os.path.exists(full):
                _point(block, full)
        repoint_data([old])


def repoint_data(bases=None):
    """The images and volumes of the bakes the file records or shows, whose relative paths
    lead nowhere, pointed at their files again, found from ``bases`` (default: the folders the
    records, and the data's own, say the .blend was in). A Save As with Remap Relative off
    keeps every relative path as it was, now relative to the new folder (measured: a glass's
    normal maps missing from the saved file and the session, the render without its drops).
    A file found in a bake folder no object records (a deleted object's bake) is taken only
    for data that recorded a base when saved (DATA_BASE): an artist's own image is never
    repointed into a bake."""
    folders, recorded = [], set()
    for obj in bpy.data.objects:
        if obj.library is not None:
            continue
        for group, _key, base_key, folder, _rebuild in _records(obj):
            if folder:
                full = resolve(folder, group.get(base_key))
                folders.append(os.path.dirname(full) if os.path.isfile(full) else full)
            if group.get(base_key):
                recorded.add(group[base_key])
    for block in (*bpy.data.images, *bpy.data.volumes):
        path = block.filepath
        if block.library is not None or not path.startswith("//") or \
                os.path.exists(bpy.path.abspath(path)):
            continue
        own = block.get(DATA_BASE)
        tried = bases if bases is not None else sorted(recorded | ({own} if own else set()))
        for base in tried:
            there = os.path.normpath(os.path.join(base, path[2:]))
            if os.path.exists(there) and (_inside(there, folders) or
                                          (own and _in_bake_folder(there))):
                _point(block, there)
                break


def _point(block, path):
    """An image or volume pointed at the file ``path``, relative to the .blend if it can be."""
    try:
        block.filepath = bpy.path.relpath(path)
    except ValueError:  # another drive (Windows): absolute
        block.filepath = path


def _rebase(full_of):
    """Each relative record made relative to the .blend's folder, pointing at ``full_of(folder,
    base)`` (left as it is where that is None), and that folder recorded as its base."""
    now = here()
    if not now:
        return
    for obj in bpy.data.objects:
        if obj.library is not None:
            continue
        for group, key, base_key, folder, rebuild in list(_records(obj)):
            if not folder.startswith("//"):
                continue
            full = full_of(folder, group.get(base_key))
            if full is None:
                continue
            if full != os.path.normpath(bpy.path.abspath(folder)):
                try:
                    group[key] = rebuild(bpy.path.relpath(full))
                except ValueError:  # another drive (Windows): absolute
                    group[key] = rebuild(full)
            if group.get(base_key) != now:
                group[base_key] = now


def shown_from(folder, prefixes=None):
    """Whether an image, a volume or a recorded mesh sequence of the file (one whose name
    starts with one of ``prefixes``, if given) reads files in ``folder`` (a deleted object's
    bake, its wiring still in the file)."""
    def under(block, path, library=None):
        return (prefixes is None or block.name.startswith(tuple(prefixes))) and \
            _inside(bpy.path.abspath(path, library=library), [folder])
    if any(b.filepath and under(b, b.filepath, b.library)
           for b in (*bpy.data.images, *bpy.data.volumes)):
        return True
    from .bridge import frame_meshes
    return any(isinstance(o.get(frame_meshes.PROP), str) and
               under(o, resolve(o[frame_meshes.PROP].split("|", 2)[1],
                                o.get(frame_meshes.PROP_BASE), o.library))
               for o in bpy.data.objects)


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
    def rel(path):
        full = os.path.abspath(bpy.path.abspath(path))
        if not path or not _inside(full, [bpy.path.abspath(root)]):
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
        for group, key, base_key, folder, rebuild in list(_records(obj)):
            full = resolve(folder, group.get(base_key)) if folder else ""
            if rel(full) != full:
                record(group, key, rebuild(rel(full)), base_key, rel(full))
