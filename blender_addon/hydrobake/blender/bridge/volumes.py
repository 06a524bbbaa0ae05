"""Baked VDB sequences as Blender Volume objects."""
import os

import bpy


def load_volume_sequence(folder, stream, frame_start, frame_count, name, collection=None):
    """A Volume object reading ``<folder>/<stream>_####.vdb`` as a sequence (reused by name)."""
    path = os.path.join(folder, f"{stream}_{frame_start:04d}.vdb")
    vol = bpy.data.volumes.get(name) or bpy.data.volumes.new(name)
    vol.filepath = path
    vol.is_sequence = frame_count > 1
    vol.frame_start = frame_start
    vol.frame_duration = frame_count
    vol.frame_offset = frame_start - 1
    vol.sequence_mode = "CLIP"
    obj = bpy.data.objects.get(name)
    if obj is None:
        obj = bpy.data.objects.new(name, vol)
        (collection or bpy.context.scene.collection).objects.link(obj)
    vol.grids.load()
    return obj


def grid_names(volume):
    volume.grids.load()
    return {g.name: g.data_type for g in volume.grids}
