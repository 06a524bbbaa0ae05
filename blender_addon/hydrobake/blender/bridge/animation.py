"""A scene's animation sampled frame by frame, for the inputs a bake reads per frame."""
import contextlib


_reporter = None  # called (frame, done, total) after each frame per_frame takes


@contextlib.contextmanager
def reporting(fn):
    """per_frame reports each frame it takes to ``fn(frame, done, total)`` within the block:
    stepping a heavy scene through a bake's frames can take a while on the main thread."""
    global _reporter
    outer, _reporter = _reporter, fn
    try:
        yield
    finally:
        _reporter = outer


def per_frame(scene, first, last, fn):
    """{frame: fn(frame)} for every frame from first to last, each taken with the scene set to
    that frame; the scene's own frame is restored afterwards, also when fn raises."""
    keep = scene.frame_current
    out = {}
    try:
        for f in range(first, last + 1):
            scene.frame_set(f)
            out[f] = fn(f)
            if _reporter is not None:
                _reporter(f, f - first + 1, last - first + 1)
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
