"""Baked VDB sequences as Blender Volume objects."""
import os

import bpy

from ...core.bake.cache import frame_path
from .depsgraph import evaluated as evaluated_depsgraph


def load_volume_sequence(folder, stream, frame_start, frame_count, name, collection=None):
    """A Volume object reading the bake's ``<folder>/<tag><stream>_####.vdb`` as a sequence
    (reused by name: the object's own volume data is the one set, whatever it is called; a
    new object gets the volume data of that name, or a new one)."""
    path = frame_path(folder, stream, frame_start, "vdb")
    obj = bpy.data.objects.get(name)
    if obj is not None and obj.type != "VOLUME":
        raise ValueError(f"{name}: the name of a {obj.type.lower()} object, not a volume; "
                         "rename it")
    if obj is not None and obj.data is not None:
        vol = obj.data
    else:
        vol = bpy.data.volumes.get(name)
        if vol is None or vol.library is not None:
            vol = bpy.data.volumes.new(name)
    vol.filepath = path
    if vol.packed_file is not None and os.path.exists(path):
        drop_packed(vol)
    vol.is_sequence = frame_count > 1
    vol.frame_start = frame_start
    vol.frame_duration = frame_count
    vol.frame_offset = frame_start - 1  # scene frame N reads file number N
    vol.sequence_mode = "CLIP"
    if obj is None:
        obj = bpy.data.objects.new(name, vol)
        (collection or bpy.context.scene.collection).objects.link(obj)
    return obj


def drop_packed(vol):
    """Lets a volume packed by Pack Resources read its file again (it would go on showing the
    old bake). Volumes have no unpack of their own; the operator's Use Original File takes the
    file at the volume's path, which must exist: else it writes the packed copy there."""
    id_type = ord("V") | ord("O") << 8  # Blender's ID code of volumes, "VO"
    bpy.ops.file.unpack_item(method="USE_ORIGINAL", id_name=vol.name, id_type=id_type)


def grid_names(obj, depsgraph=None):
    """{grid name: data type} of a Volume object at the current frame. A sequence is read
    through the evaluated object: the original volume does not follow the frame."""
    depsgraph = depsgraph or evaluated_depsgraph()
    vol = obj.evaluated_get(depsgraph).data
    vol.grids.load()
    if vol.grids.error_message:
        raise OSError(f"{obj.name}: {vol.grids.error_message}")
    return {g.name: g.data_type for g in vol.grids}
