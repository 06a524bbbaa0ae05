"""Mantaflow liquid caches as the fluid's velocity source, without Blender: unit conversion,
MAC sampling, the surface field from crossings, and errors."""
import numpy as np
import pytest

from hydrobake.core import errors, mantaflow, vdb


def test_uniform_mac_velocity_converts_to_metres_per_second():
    # 10 cells over 2 m: 0.2 m cells; 3 cells per Manta time unit = 3 * 0.2 * 2.5 m/s.
    dense = np.zeros((10, 10, 10, 3), np.float32)
    dense[..., 0], dense[..., 2] = 3.0, -1.0
    pts = mantaflow.vertex_positions((0, 0, 0), (2, 2, 2), (4, 4, 4))
    v = mantaflow.velocity_at(dense, (0, 0, 0), (2, 2, 2), pts)
    np.testing.assert_allclose(v[..., 0], 1.5, rtol=1e-6)
    np.testing.assert_allclose(v[..., 2], -0.5, rtol=1e-6)
    np.testing.assert_allclose(v[..., 1], 0.0)
    # A slowed simulation (time scale 0.5) moves half as far per frame.
    v2 = mantaflow.velocity_at(dense, (0, 0, 0), (2, 2, 2), pts, time_scale=0.5)
    np.testing.assert_allclose(v2, 0.5 * v, rtol=1e-6)


def test_mac_components_are_read_on_their_faces():
    # u = x-face index: on face i the x component sits at x = i h, so u(x) = x / h exactly
    # (linear, so trilinear sampling is exact away from the clamped edges).
    n, h = 8, 0.25
    dense = np.zeros((n, n, n, 3), np.float32)
    dense[..., 0] = np.arange(n, dtype=np.float32)[:, None, None]
    dense[..., 1] = np.arange(n, dtype=np.float32)[None, :, None] * 2
    pts = np.array([[0.3, 0.9, 1.0], [1.1, 0.5, 0.6], [0.75, 1.2, 0.4]])
    v = mantaflow.velocity_at(dense, (0, 0, 0), (n * h,) * 3, pts)
    np.testing.assert_allclose(v[:, 0], pts[:, 0] / h * h * 2.5, rtol=1e-6)
    np.testing.assert_allclose(v[:, 1], 2 * pts[:, 1] / h * h * 2.5, rtol=1e-6)


def test_surface_field_is_half_on_the_crossings_and_above_inside():
    z = np.linspace(0.0, 1.0, 11)
    counts = np.array([[2, 0], [4, 1]], np.int32)  # lines (y, x): slab, none, two slabs, open
    crossings = np.array([0.3, 0.7, 0.1, 0.25, 0.6, 0.9, 0.5], np.float32)
    f = mantaflow.surface_field(crossings, counts, z, 0.1)
    assert f.shape == (11, 2, 2)
    slab = f[:, 0, 0]
    np.testing.assert_allclose(slab[[3, 7]], 0.5, atol=1e-6)  # on the crossings
    np.testing.assert_allclose(slab[5], 1.0)                    # 0.2 inside: clamped
    np.testing.assert_allclose(slab[[0, 10]], 0.0)             # far outside
    assert slab[4] > 0.5 > slab[2]
    np.testing.assert_allclose(f[:, 0, 1], 0.0)                 # no liquid on that line
    two = f[:, 1, 0]
    assert two[2] > 0.5 and two[4] < 0.5 and two[8] > 0.5 and two[10] < 0.5
    np.testing.assert_allclose(f[:, 1, 1], 0.0)                 # an unmatched crossing: ignored


def test_cache_source_reads_a_mantaflow_style_file(tmp_path):
    (tmp_path / "data").mkdir()
    res = 6
    vel = np.zeros((res, res, res, 3), np.float32)
    vel[..., 2] = -2.0
    g = vdb.make_grid("velocity", vel, voxel_size=1.0 / res,
                      metadata={"file_base_resolution": (res, res, res)})  # as Blender writes
    vdb.write(mantaflow.data_path(str(tmp_path), 3), [g])
    src = mantaflow.CacheSource(str(tmp_path), [3, 4], (0, 0, 0), (1, 1, 1), (0, 0, 0),
                                (1, 1, 1), (4, 4, 4))
    assert 3 in src and 5 not in src
    v, field = src[3]
    assert v.shape == (5, 5, 5, 3) and field is None
    np.testing.assert_allclose(v[..., 2], -2.0 / res * 2.5, rtol=1e-6)
    with pytest.raises(errors.FileIOError, match="no Mantaflow data"):
        src[4]
    with pytest.raises(KeyError):
        src[5]
