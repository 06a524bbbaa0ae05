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


def paper_temperature_chance(t):
    """Ise §4.1.2-4.1.5, written out independently: at and above -2 degC surface tension by
    water content (5 % at -2 to 25 % at 3 degC, linear; 7 % chance at 5 %, 25 % at 15 %, 7 %
    at 25 %, linear between), below it sintering (2 % at -10 to 10 % at -2 degC, linear)."""
    if t >= -2.0:
        w = 5.0 + (t + 2.0) * 20.0 / 5.0
        return (7.0 + (w - 5.0) * 18.0 / 10.0 if w <= 15.0 else 25.0 - (w - 15.0) * 18.0 / 10.0) / 100
    return (2.0 + (t + 10.0) * 8.0 / 8.0) / 100


def test_sticking_curve_over_the_papers_temperature_range():
    # Every temperature the paper allows (-10..3 degC, §4.1.1), every catch preset (§4.1.6:
    # smooth 0, shoes 0.1, trousers 0.25, coat 0.4, the most 0.5), independent mechanisms.
    for t in np.linspace(-10.0, 3.0, 131):
        pt = paper_temperature_chance(float(np.float32(t)))
        for c in (0.0, 0.1, 0.25, 0.4, 0.5):
            assert snow.hit_chance(t, c) == pytest.approx(1 - (1 - pt) * (1 - c), abs=1e-6)
        # the stamp: wet (bleeding, D linear in the water content: 0.1 at 5 %, 1 at 25 %) at
        # and above -2 degC, dry below; centre, side and corner cells
        a = snow.stamp_alpha(t, 0.25)
        if t >= -2.0:
            d = 0.1 + (snow.water_content(t) - 5.0) * 0.9 / 20.0
            want = [110 + 25 * 0.25 - 48 * d, 25 + 10 * 0.25 + 12 * d, 10 + 5 * 0.25 + 9 * d]
        else:
            want = [90 + 90 * 0.25, 10 + 15 * 0.25, 5 + 10 * 0.25]
        assert a[1, 1] == pytest.approx(want[0], abs=1e-4)
        assert a[0, 1] == a[1, 0] == a[1, 2] == a[2, 1] == pytest.approx(want[1], abs=1e-4)
        assert a[0, 0] == a[0, 2] == a[2, 0] == a[2, 2] == pytest.approx(want[2], abs=1e-4)


@pytest.mark.parametrize("temp,catch", [(-1.0, 0.0), (-8.0, 0.25)])
def test_sticking_rate_of_many_flakes_follows_the_curve(temp, catch):
    # Flakes falling on a wide flat plate: the share of contacts that stick is the chance,
    # within four binomial standard errors (fixed seed).
    with snow.Snow({"flake_count": 10000, "temperature": temp, "wind": (0, 0, 0),
                    "volume_min": (-1, -1, 0), "volume_max": (1, 1, 1), "time_step": 0.05,
                    "texture_width": 32, "texture_height": 32, "seed": 7, "threads": 1}) as s:
        s.set_materials([(catch, False, False)])
        pos = np.array([[-2, -2, 0.2], [2, -2, 0.2], [2, 2, 0.2], [-2, 2, 0.2]], np.float32)
        tri = np.array([[0, 1, 2], [0, 2, 3]], np.int32)
        s.set_mesh(pos, tri, np.tile(np.array([[0, 0], [1, 0], [1, 1]], np.float32), (2, 1, 1)))
        while s.stats()["hits"] < 20000:
            s.step(20)
        st = s.stats()
        n = st["stuck"] + st["bounced"]
        want = 1 - (1 - paper_temperature_chance(temp)) * (1 - catch)
        assert abs(st["stuck"] / n - want) <= 4 * np.sqrt(want * (1 - want) / n)
        assert st["hits"] == n  # nothing melted or shed
