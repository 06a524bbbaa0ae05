"""A mesh that deforms (a walking person) is given to the snow effect as its vertices per frame
(frame_positions), each kept until the next frame given. A shape that is only the rigid motion
gives the bytes of that motion given as a transform; a shape that changes lays the snow where
the mesh is then; a resume checks the kept frames' shapes; bad shapes are refused by name."""
import numpy as np
import pytest

from hydrobake.core import errors
from hydrobake.core.bake import BakeCache
from hydrobake.core.effects import get
from test_resume_scene import MI, MOVED, POS, TRIS, UVS, frames, refused, run

PARAMS = {"snow": {"flake_count": 3000, "texture_width": 32, "texture_height": 32,
                   "wind": (1, 0, 0), "flake_radius": 0.01}}
MATERIALS = [(0.4, False, False), (0.0, False, True)]


def snow(**given):
    return get("snow")(PARAMS, dict({"positions": POS, "triangles": TRIS, "uvs": UVS,
                                     "material_index": MI, "substeps": 2,
                                     "materials": MATERIALS}, **given))


def moved(pos, m):
    return (pos.astype(np.float64) @ m[:3, :3].T + m[:3, 3]).astype(np.float32)


def squashed(pos, z):
    """The box squashed to a fraction ``z`` of its height above the ground (the roof stays:
    it is the vertices past the box's)."""
    out = pos.copy()
    out[:8, 2] *= z
    return out


def test_a_rigid_shape_gives_the_bytes_of_its_transform(tmp_path):
    run(snow(transforms={3: MOVED}), tmp_path / "t")
    run(snow(frame_positions={3: moved(POS, MOVED)}), tmp_path / "s")
    assert frames(tmp_path / "s") == frames(tmp_path / "t")


def test_snow_lands_where_the_shape_is(tmp_path):
    """Until the box is squashed its bake is the still box's, byte for byte; after, the
    snow differs (it lands on a lower top)."""
    run(snow(), tmp_path / "still")
    run(snow(frame_positions={5: squashed(POS, 0.3)}), tmp_path / "squashed")
    still, sq = frames(tmp_path / "still"), frames(tmp_path / "squashed")
    early = [n for n in still if int(n.split("_")[-1].split(".")[0]) < 5]
    assert early and all(sq[n] == still[n] for n in early)
    assert sq["coverage_0008.exr"] != still["coverage_0008.exr"]
    m = BakeCache(tmp_path / "squashed").read_manifest()["frame_inputs"]
    assert m["4"] == m["1"] != m["5"] == m["8"]  # the shape held until the next given


def test_a_resume_checks_the_kept_frames_shapes(tmp_path):
    """Cancelled after frame 5: a shape changed at frame 3 is refused; one changed at frame 6
    is baked as it is now, and the result is the bake of the new shapes."""
    shapes = {3: squashed(POS, 0.5), 6: squashed(POS, 0.3)}
    cut = tmp_path / "cut"
    run(snow(frame_positions=shapes), cut, cancel_after=5)
    refused(snow(frame_positions={**shapes, 3: squashed(POS, 0.6)}), cut,
            "mesh position at frame 3: changed since the bake")
    later = {**shapes, 6: squashed(POS, 0.2)}
    r = run(snow(frame_positions=later), cut, resume=True)
    run(snow(frame_positions=later), tmp_path / "ref")
    assert r.resumed_from == 5 and frames(cut) == frames(tmp_path / "ref")


@pytest.mark.parametrize("given, want", [
    ({"frame_positions": {2: POS[:-1]}}, r"frame_positions\[2\]: shape \(\d+, 3\), need"),
    ({"frame_positions": {2: POS.ravel()}}, r"frame_positions\[2\]: shape"),
    ({"frame_positions": {2: POS}, "transforms": {3: MOVED}},
     "frame_positions: give them or transforms, not both"),
])
def test_bad_shapes_are_refused_by_name(given, want):
    with pytest.raises(errors.InvalidArgument, match=want):
        snow(**given)


def test_a_non_finite_shape_is_refused_when_set(tmp_path):
    bad = POS.copy()
    bad[0, 0] = np.nan
    e = snow(frame_positions={2: bad})
    with pytest.raises(errors.InvalidArgument):
        run(e, tmp_path / "nan", end=3)
