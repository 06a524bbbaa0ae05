"""A scene's animation sampled frame by frame, for the inputs a bake reads per frame."""


def per_frame(scene, first, last, fn):
    """{frame: fn(frame)} for every frame from first to last, each taken with the scene set to
    that frame; the scene's own frame is restored afterwards, also when fn raises."""
    keep = scene.frame_current
    out = {}
    try:
        for f in range(first, last + 1):
            scene.frame_set(f)
            out[f] = fn(f)
    finally:
        scene.frame_set(keep)
    return out
