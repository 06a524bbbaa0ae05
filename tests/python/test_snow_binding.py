"""Snow through the binding: the paper's formulas, parameter errors, a bake on a box under a
roof, determinism and resume."""
import numpy as np
import pytest

from hydrobake.core import errors, snow
from hydrobake.core.bake import BakeCache, BakeRunner
from hydrobake.core.effects import get


def test_formulas_follow_the_paper():
    assert snow.water_content(-2.0) == pytest.approx(5.0)
    assert snow.water_content(3.0) == pytest.approx(25.0)
    assert snow.water_content(0.5) == pytest.approx(15.0)
    assert snow.hit_chance(0.5) == pytest.approx(0.25)   # 15 % water: the tension peak
    assert snow.hit_chance(-10.0) == pytest.approx(0.02)  # sintering
    assert snow.hit_chance(-6.0) == pytest.approx(0.06)
    assert snow.hit_chance(-6.0, 0.4) == pytest.approx(1 - 0.94 * 0.6)  # independent chances
    dry = snow.stamp_alpha(-5.0, 0.5)
    np.testing.assert_allclose(dry, [[10, 17.5, 10], [17.5, 135, 17.5], [10, 17.5, 10]])
    wet = snow.stamp_alpha(3.0, 0.0)  # D = 1 at 25 %: u + w
    np.testing.assert_allclose(wet, [[19, 37, 19], [37, 62, 37], [19, 37, 19]])


def test_bad_parameters_name_themselves():
    with pytest.raises(errors.InvalidArgument, match=r"^temperature = 9: must be in \[-10, 3\]"):
        snow.Snow({"temperature": 9})
    with pytest.raises(errors.InvalidArgument, match="contact_mode = 'SPHERE'"):
        snow.Snow({"contact_mode": "SPHERE"})
    with snow.Snow({"flake_count": 100}) as s:
        with pytest.raises(errors.InvalidArgument, match="triangle"):
            s.set_mesh(np.zeros((3, 3)), np.array([[0, 1, 5]]), np.zeros((1, 3, 2)))


def box_with_roof():
    """A unit cube on the ground (slot 0) under a wide roof (slot 1, sheds)."""
    v = np.array([[x, y, z] for z in (0, 1) for y in (-.5, .5) for x in (-.5, .5)], np.float32)
    quads = [(0, 1, 3, 2), (4, 5, 7, 6), (0, 1, 5, 4), (2, 3, 7, 6), (0, 2, 6, 4), (1, 3, 7, 5)]
    tris = [t for a, b, c, d in quads for t in ((a, b, c), (a, c, d))]
    roof = np.array([[-1.5, -1.5, 1.6], [1.5, -1.5, 1.6], [1.5, 1.5, 1.6], [-1.5, 1.5, 1.6]],
                    np.float32)
    pos = np.vstack([v, roof])
    tris += [(8, 9, 10), (8, 10, 11)]
    uvs = np.tile(np.array([[0.1, 0.1], [0.9, 0.1], [0.9, 0.9]], np.float32), (len(tris), 1, 1))
    mi = np.array([0] * 12 + [1, 1], np.int32)
    return pos, np.array(tris, np.int32), uvs, mi


def bake(folder, threads=0, frames=(1, 4), resume=False):
    pos, tris, uvs, mi = box_with_roof()
    e = get("snow")({"snow": {"flake_count": 20000, "texture_width": 64, "texture_height": 64,
                              "wind": (0, 0, 0), "threads": threads, "flake_radius": 0.01}},
                    {"positions": pos, "triangles": tris, "uvs": uvs, "material_index": mi,
                     "materials": [(0.4, False, False), (0.0, False, True)], "substeps": 10})
    r = BakeRunner(e, folder, *frames, checkpoint_every=2, resume=resume)
    r.run()
    stats = e.snow.stats()
    e.close()
    return stats


def test_roof_shelters_the_box_and_bytes_do_not_depend_on_threads(tmp_path):
    stats = bake(tmp_path / "a", threads=1)
    bake(tmp_path / "b", threads=2)
    for i in range(1, 5):
        for st in ("coverage", "depth"):
            assert (tmp_path / "a" / f"{st}_{i:04d}.exr").read_bytes() == \
                (tmp_path / "b" / f"{st}_{i:04d}.exr").read_bytes()
    assert stats["shed"] > 0      # flakes landed on the roof and were removed
    assert stats["stuck"] == 0    # nothing reached the sheltered box without wind


def test_resume_continues_bit_identically(tmp_path):
    bake(tmp_path / "full", frames=(1, 6))
    bake(tmp_path / "cut", frames=(1, 3))
    bake(tmp_path / "cut", frames=(1, 6), resume=True)
    for i in range(1, 7):
        assert (tmp_path / "full" / f"depth_{i:04d}.exr").read_bytes() == \
            (tmp_path / "cut" / f"depth_{i:04d}.exr").read_bytes()
    assert BakeCache(tmp_path / "cut").verify() == []
