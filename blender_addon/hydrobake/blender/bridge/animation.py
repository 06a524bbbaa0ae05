"""A scene's animation sampled frame by frame, for the inputs a bake reads per frame."""
import contextlib

import numpy as np

from . import meshes
from .depsgraph import evaluated as evaluated_depsgraph


def per_frame(scene, first, last, fn):
    """A generator (``got = yield from per_frame(...)``) giving {frame: fn(frame)} for every
    frame from first to last, each taken with the scene set to that frame. After each frame
    it yields (frame, done, total), so that whoever drives it shows progress and can stop it
    between frames (Blender reads no events while Python runs: a UI bake steps it from a
    timer, and Esc closes it). The scene's own frame is restored afterwards, also when fn
    raises or the generator is closed."""
    keep = scene.frame_current
    out = {}
    try:
        for f in range(first, last + 1):
            scene.frame_set(f)
            out[f] = fn(f)
            yield f, f - first + 1, last - first + 1
    finally:
        scene.frame_set(keep)
    return out


@contextlib.contextmanager
def at_frame(scene, frame, always=False):
    """The scene set to ``frame`` for the block (its shapes and places evaluated there from
    the animation), and set back to the frame and subframe it was on afterwards, also when
    the block raises. A scene already there is set again only ``always``: setting a frame
    evaluates the whole scene, and undoes changes to animated properties not keyed yet."""
    keep, sub = scene.frame_current, scene.frame_subframe
    if keep == frame and sub == 0.0 and not always:
        yield
        return
    scene.frame_set(frame)
    try:
        yield
    finally:
        scene.frame_set(keep, subframe=sub)


def followed(context, obj, frames, read, same=np.array_equal, animated=False):
    """(read at the bake's first frame, {frame: read} for the later frames where it differs
    from the frame before, by ``same``): the path only for an object animated, constrained
    or deformed, or when ``animated`` (what read reads is keyed). A generator, as per_frame;
    read(depsgraph) takes the scene at its frame."""
    first, path = read(evaluated_depsgraph(context)), {}
    if (animated or may_move(obj) or may_deform(obj)) and frames[1] > frames[0]:
        got = yield from per_frame(context.scene, frames[0] + 1, frames[1],
                                   lambda _f: read(evaluated_depsgraph(context)))
        last = first
        for f, a in got.items():
            if not same(a, last):
                path[f] = last = a
    return first, path


def property_animated(settings, name):
    """Whether the property ``name`` of ``settings`` (a property group of an ID) is keyed or
    driven (its ID's action, an NLA strip's or a driver), so that it may change from frame
    to frame."""
    ad = settings.id_data.animation_data
    if ad is None:
        return False
    path = settings.path_from_id(name)
    actions = [ad.action] + [s.action for t in ad.nla_tracks for s in t.strips]
    return (any(fc.data_path == path for a in actions if a is not None for fc in a.fcurves) or
            any(d.data_path == path for d in ad.drivers))


def may_move(obj):
    """Whether the object's world matrix may change from frame to frame: it or a parent is
    animated (action, NLA, drivers), constrained, a rigid body, or parented to a bone or to
    vertices. (A frame change handler moving it is not seen.)"""
    while obj is not None:
        ad = obj.animation_data
        if ad is not None and (ad.action is not None or len(ad.drivers) or
                               len(ad.nla_tracks)):
            return True
        if len(obj.constraints) or obj.rigid_body is not None or obj.parent_type != "OBJECT":
            return True
        obj = obj.parent
    return False


# Objects Blender evaluates to a mesh (Object.to_mesh): a shape, not only a box.
SHAPED_TYPES = {"MESH", "CURVE", "SURFACE", "FONT", "META"}

# Modifiers whose result depends on the mesh alone: the shape they give changes only when
# something animates their settings (the object's own animation data).
STILL_MODIFIERS = {"SUBSURF", "MULTIRES", "SOLIDIFY", "BEVEL", "TRIANGULATE", "EDGE_SPLIT",
                   "WELD", "DECIMATE", "REMESH", "WEIGHTED_NORMAL", "SKIN", "WIREFRAME"}


def may_deform(obj, skip=None):
    """Whether the object's evaluated shape may change from frame to frame: a modifier (but
    ``skip``) that can take the frame or another object's motion (an armature, a cloth, a
    wave, a lattice, geometry nodes), any modifier of an object with animation data (a keyed
    Subdivision level), or animated shape keys or data (a mesh's, or a curve's, a text's or a
    metaball's: a keyed bevel, body or radius). A metaball's family melts into one surface
    held in its basis's axes: a member's shape changes when any member moves or changes."""
    if obj.type not in SHAPED_TYPES:
        return False
    if obj.type == "META":
        family = meshes.metaball_family(obj)
        return any(m.data.animation_data is not None or (len(family) > 1 and may_move(m))
                   for m in family)
    mods = [m for m in obj.modifiers if m.show_viewport and m != skip]
    if mods and obj.animation_data is not None:
        return True
    if any(m.type not in STILL_MODIFIERS and not (m.type == "MIRROR" and m.mirror_object is None)
           for m in mods):
        return True
    return any(d is not None and d.animation_data is not None
               for d in (obj.data, getattr(obj.data, "shape_keys", None)))
