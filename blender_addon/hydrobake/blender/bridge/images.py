"""Baked image sequences as Blender images."""

import bpy
import numpy as np

from ...core.bake.cache import frame_path


def load_sequence(folder, stream, frame_start, frame_count, name=None, colorspace="Non-Color"):
    """An image datablock reading the bake's ``<folder>/<tag><stream>_####.exr`` as a
    sequence. Reuses an image of the same name, so re-baking refreshes rather than
    duplicates."""
    first = frame_path(folder, stream, frame_start, "exr")
    name = name or f"HBK_{stream}"
    img = bpy.data.images.get(name)
    if img is None:
        img = bpy.data.images.load(first, check_existing=False)
        img.name = name
    else:
        if img.packed_file is not None:  # (Pack Resources) dropped first: a reload re-packs
            img.unpack(method="REMOVE")  # the old path's file, or keeps the old bake's
        img.filepath = first
    img.source = "SEQUENCE" if frame_count > 1 else "FILE"  # one frame: every frame shows it
    img.colorspace_settings.name = colorspace
    img.reload()
    return img


def load_unused_sequence(folder, stream, frame_start, frame_count, name, colorspace="Linear"):
    """load_sequence for an image no node shows (a preview to look at in the Image Editor): a
    fake user keeps it in the saved file, where Blender drops datablocks without users."""
    img = load_sequence(folder, stream, frame_start, frame_count, name, colorspace)
    img.use_fake_user = True
    return img


def remove(name):
    """Removes the image ``name`` (one of ours) if nothing but its fake user holds it."""
    img = bpy.data.images.get(name)
    if img is not None and img.users <= int(img.use_fake_user):
        bpy.data.images.remove(img)


def configure_user(image_user, frame_start, frame_count):
    """Makes a node's image user play the sequence in step with the scene, holding the first
    file before it and the last after. (Blender clamps the frame into [0, duration] and adds
    the offset: starting one frame later with one frame less makes 0 the first file, where
    the plain start = first, offset = first - 1 asked for the missing file first - 1.)"""
    image_user.frame_start = frame_start + 1
    image_user.frame_offset = frame_start
    image_user.frame_duration = max(frame_count - 1, 1)  # one frame: a FILE, not a sequence
    image_user.use_auto_refresh = True
    image_user.use_cyclic = False


def pixels(img, colour=False, role="Image"):
    """An image's pixels as a (h, w, channels) float32 array, row 0 at the bottom. colour:
    the values are colours wanted in scene-linear light; an 8-bit sRGB image's pixels are its
    sRGB values (Blender linearises only float images), so they are linearised here. An
    image without pixels is a ValueError naming ``role``, the setting it is."""
    if not has_pixels(img):
        raise ValueError(f"{role}: image '{img.name}' has no pixels (its file "
                         f"{img.filepath or '(none)'} is missing?)")
    w, h = img.size
    buf = np.empty(w * h * img.channels, dtype=np.float32)
    img.pixels.foreach_get(buf)
    px = buf.reshape(h, w, img.channels)
    if colour and not img.is_float and img.colorspace_settings.name == "sRGB":
        rgb = px[..., :3]
        px[..., :3] = np.where(rgb <= 0.04045, rgb / 12.92,
                               ((rgb + 0.055) / 1.055) ** 2.4).astype(np.float32)
    return px


def has_pixels(img):
    """Whether the image has data to read (a file moved away leaves it empty)."""
    return img.has_data or (img.size[0] > 0 and img.size[1] > 0 and len(img.pixels) > 0)


def set_pixels(img, arr):
    """Writes a (h, w, channels) array into an image of that size."""
    img.pixels.foreach_set(np.ascontiguousarray(arr, dtype=np.float32).ravel())
    img.update()
