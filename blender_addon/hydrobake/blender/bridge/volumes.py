"""Baked VDB sequences as Blender Volume objects."""
import os

import bpy

from .depsgraph import evaluated as evaluated_depsgraph


def load_volume_sequence(folder, stream, frame_start, frame_count, name, collection=None):
    """A Volume object reading ``<folder>/<stream>_####.vdb`` as a sequence (reused by name:
    the object's own volume data is the one set, whatever it is called; a new object gets
    the volume data of that name, or a new one)."""
    path = os.path.join(folder, f"{stream}_{frame_start:04d}.vdb")
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
    vol.is_sequence = frame_count > 1
    vol.frame_start = frame_start
    vol.frame_duration = frame_count
    vol.frame_offset = frame_start - 1  # scene frame N reads file number N
    vol.sequence_mode = "CLIP"
    if obj is None:
        obj = bpy.data.objects.new(name, vol)
        (collection or bpy.context.scene.collection).objects.link(obj)
    return obj


def grid_names(obj, depsgraph=None):
    """{grid name: data type} of a Volume object at the current frame. A sequence is read
    through the evaluated object: the original volume does not follow the frame."""
    depsgraph = depsgraph or evaluated_depsgraph()
    vol = obj.evaluated_get(depsgraph).data
    vol.grids.load()
    if vol.grids.error_message:
        raise OSError(f"{obj.name}: {vol.grids.error_message}")
    return {g.name: g.data_type for g in vol.grids}
