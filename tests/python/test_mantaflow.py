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


def test_a_turned_and_scaled_domain_gives_world_velocity_at_world_points():
    # The domain's object space: a 2 x 1 x 1 box from (0, 0, 0), 8 x 4 x 4 cells (0.25 per
    # cell), turned a quarter about z, then scaled 3x along its own x (a world cell 0.75 m
    # along the object's x) and moved. Mantaflow simulates along the object's axes: a uniform
    # flow of 2 cells per time unit along its x is 2 * 0.75 * 2.5 m/s along the world's +y.
    dense = np.zeros((8, 4, 4, 3), np.float32)
    dense[..., 0] = 2.0
    dense[..., 2] = np.arange(8, dtype=np.float32)[:, None, None]  # z flow grows along obj x
    turn = np.array([[0, -1, 0, 0], [1, 0, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]], np.float64)
    scale = np.diag([3.0, 1.0, 1.0, 1.0])
    move = np.eye(4)
    move[:3, 3] = (5.0, -1.0, 2.0)
    m = move @ turn @ scale
    # World points at the object-space points (x, 0.5, 0.5): x = 0.25 i lies on x-face i.
    obj = np.array([[0.5, 0.5, 0.5], [1.0, 0.5, 0.5], [1.5, 0.5, 0.5]])
    world = obj @ m[:3, :3].T + m[:3, 3]
    v = mantaflow.velocity_at(dense, (0, 0, 0), (2, 1, 1), world, matrix=m)
    np.testing.assert_allclose(v[:, 0], 0.0, atol=1e-5)
    np.testing.assert_allclose(v[:, 1], 2.0 * 0.75 * 2.5, rtol=1e-5)
    # The z component (cell-centred along x: face z sits at x = 0.25 (i + 0.5)) follows the
    # object's x, not the world's.
    np.testing.assert_allclose(v[:, 2], (obj[:, 0] / 0.25 - 0.5) * 0.25 * 2.5, rtol=1e-5)



def test_cache_source_turns_a_turned_domains_velocity_into_the_world(tmp_path):
    # A 1 x 2 x 1 domain turned a quarter about z: its own y runs along the world's -x.
    (tmp_path / "data").mkdir()
    vel = np.zeros((4, 8, 4, 3), np.float32)
    vel[..., 1] = 1.0  # 1 cell (0.25 m) per time unit along the object's y
    g = vdb.make_grid("velocity", vel, voxel_size=0.25,
                      metadata={"file_base_resolution": (4, 8, 4)})
    vdb.write(mantaflow.data_path(str(tmp_path), 1), [g])
    m = np.array([[0, -1, 0, 0], [1, 0, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]], np.float64)
    src = mantaflow.CacheSource(str(tmp_path), [1], (0, 0, 0), (1, 2, 1), (-2, 0, 0),
                                (0, 1, 1), (4, 4, 4), matrix=m)
    v, _ = src[1]
    np.testing.assert_allclose(v[..., 0], -0.25 * 2.5, rtol=1e-5)
    np.testing.assert_allclose(v[..., 1:], 0.0, atol=1e-6)
