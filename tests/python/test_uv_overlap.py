"""image.uv_overlap through the binding: the share of a UV layout covered twice."""
import numpy as np
import pytest

from hydrobake.core import errors, image


def grid_uvs(n, u0=0.0, u1=1.0):
    """An n x n grid of quads over [u0, u1] x [0, 1], two triangles each: (2 n², 3, 2)."""
    us, vs = np.linspace(u0, u1, n + 1), np.linspace(0.0, 1.0, n + 1)
    tris = []
    for j in range(n):
        for i in range(n):
            a, b = (us[i], vs[j]), (us[i + 1], vs[j])
            c, d = (us[i + 1], vs[j + 1]), (us[i], vs[j + 1])
            tris += [(a, b, c), (a, c, d)]
    return np.array(tris, np.float32)


def test_a_clean_layout_does_not_overlap_and_a_mirrored_copy_does():
    """A subdivided grid shares every edge and corner and overlaps nowhere; a Mirror
    modifier's copy (the same UVs, flipped winding) lies on all of it."""
    uvs = grid_uvs(12)
    assert image.uv_overlap(uvs) == 0.0
    mirrored = uvs[:, ::-1]  # the other winding
    assert image.uv_overlap(np.concatenate([uvs, mirrored]), 128) == 1.0


def test_a_shifted_island_overlaps_by_its_share():
    """Two half-width islands offset by a quarter: a third of what is covered, twice."""
    uvs = np.concatenate([grid_uvs(4, 0.0, 0.5), grid_uvs(4, 0.25, 0.75)])
    assert image.uv_overlap(uvs, 64) == pytest.approx(1 / 3, abs=1e-6)


def test_bad_arguments_are_refused_by_name():
    with pytest.raises(errors.InvalidArgument, match=r"resolution = 0: must be in \[1, 4096\]"):
        image.uv_overlap(grid_uvs(2), 0)
    with pytest.raises(errors.InvalidArgument, match=r"uvs: must have shape \(triangles, 3, 2\)"):
        image.uv_overlap(np.zeros((4, 2), np.float32))
    assert image.uv_overlap(np.zeros((0, 3, 2), np.float32)) == 0.0
