"""Voxel solid textures for the fluid: periodic trilinear sampling, VDB tiles, the core's
noise, and the surface colour attribute of a bake."""
import numpy as np
import pytest

from hydrobake.core import errors, solid_textures
from hydrobake.core.effects import get


def test_sampling_is_trilinear_and_periodic():
    n = 8
    x = (np.arange(n) + 0.5) / n
    tex = np.zeros((n, n, n, 3), np.float32)
    tex[..., 0] = x[:, None, None]              # linear in u
    tex[..., 1] = x[None, None, :] * 2          # linear in w
    tex[..., 2] = 0.25
    uvw = np.array([[0.3, 0.7, 0.4], [0.55, 0.1, 0.6], [0.0625, 0.5, 0.9375]])
    got = solid_textures.sample(tex, uvw)
    np.testing.assert_allclose(got[:, 0], uvw[:, 0], atol=1e-6)   # exact between centres
    np.testing.assert_allclose(got[:, 1], 2 * uvw[:, 2], atol=1e-6)
    np.testing.assert_allclose(got[:, 2], 0.25, atol=1e-7)
    # One tile repeats: whole-number shifts change nothing.
    np.testing.assert_allclose(solid_textures.sample(tex, uvw + [3, -2, 1]), got, atol=1e-5)
    # Across the wrap the value blends the last and first voxels.
    edge = solid_textures.sample(tex, np.array([[0.0, 0.5, 0.5]]))[0, 0]
    assert edge == pytest.approx(0.5 * (x[0] + x[-1]))


def test_noise_tile_round_trips_through_a_vdb(tmp_path):
    path = str(tmp_path / "noise.vdb")
    solid_textures.write_noise_vdb(path, size=16, period=2, seed=3)
    tile = solid_textures.read_vdb(path)
    assert tile.shape == (16, 16, 16, 3)
    assert 0.0 <= tile.min() and tile.max() <= 1.0 and tile.std() > 0.02
    np.testing.assert_array_equal(tile[..., 0], tile[..., 2])  # a grey texture
    with pytest.raises(errors.FileIOError):
        solid_textures.read_vdb(str(tmp_path / "missing.vdb"))


def test_bake_writes_a_surface_colour_per_voxel_texture():
    tex = np.zeros((4, 4, 4, 3), np.float32)
    tex[..., 0] = ((np.arange(4) + 0.5) / 4)[:, None, None]
    tex[..., 1] = 0.5
    eff = get("fluid")({"fluid": {"resolution": (12, 12, 12), "box_max": (1, 1, 1),
                                  "textures": 2, "texture_scale": (1, 3, 1, 1, 1, 1, 1, 1)}},
                       {"fill": ((0.1, 0.1, 0.1), (0.6, 0.6, 0.5)), "voxel_textures": {1: tex}})
    try:
        eff.step(1, None)
        mesh = eff.outputs(1)["surface"][1]
    finally:
        eff.close()
    col = mesh["sample_1"]
    assert col.shape == (len(mesh["positions"]), 3) and "sample_0" not in mesh
    np.testing.assert_allclose(col[:, 1], 0.5, atol=1e-6)
    # The red channel follows u: at texture 1's scale (3), cross-faded like the material.
    w = mesh["uvw_weight"][:, None]
    want = (w * solid_textures.sample(tex, mesh["uvw_a"] * 3)
            + (1 - w) * solid_textures.sample(tex, mesh["uvw_b"] * 3))
    np.testing.assert_allclose(col, want, atol=1e-6)
    assert col[:, 0].std() > 0.05  # it varies over the surface
    unscaled = solid_textures.sample(tex, mesh["uvw_a"])[:, 0]
    assert not np.allclose(col[:, 0], unscaled, atol=1e-3)
