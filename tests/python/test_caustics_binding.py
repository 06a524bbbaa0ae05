"""Water and caustics through the binding: parameter tables, physics and contracts."""
import re

import numpy as np
import pytest

from hydrobake.core import _lib, caustics, errors
from hydrobake.core.bake import BakeRunner
from hydrobake.core.effects import get
from hydrobake.core.water import Water


def test_parameter_tables_are_complete():
    for spec in (Water.spec(), caustics.spec()):
        assert spec.params
        for p in spec.params:
            assert p.description and p.min <= p.max, p
            lo = np.atleast_1d(p.default)
            assert np.all(lo >= p.min) and np.all(lo <= p.max), p  # defaults are in range
        spec.to_struct({})  # the defaults pass the library's own checks


def test_bad_parameters_name_themselves():
    with pytest.raises(errors.InvalidArgument, match=r"^cell_size = -1: must be in \["):
        Water({"cell_size": -1})
    with pytest.raises(errors.InvalidArgument, match="substeps = 2.5: must be a whole number"):
        Water({"substeps": 2.5})
    with pytest.raises(errors.InvalidArgument, match="^wind_speed: not a parameter of water"):
        Water({"wind_speed": 3})
    with pytest.raises(errors.InvalidArgument, match=r"^ior\[0\] = 0.5"):
        caustics.render(np.zeros((8, 8)), np.full((8, 8), -1.0), 0.1, (8, 8),
                        {"ior": (0.5, 1.333, 1.333)})
    with pytest.raises(errors.InvalidArgument, match="light_direction"):
        caustics.render(np.zeros((8, 8)), np.full((8, 8), -1.0), 0.1, (8, 8),
                        {"light_direction": (0, 0, -1)})
    with pytest.raises(errors.InvalidArgument, match=r"^light\.nope: not a parameter of caustics"):
        get("caustics")({"light": {"nope": 1}})
    with pytest.raises(errors.InvalidArgument, match=r"^water\.dt = 0: must be in"):
        get("caustics")({"water": {"dt": 0}})
    with pytest.raises(errors.InvalidArgument, match="^sky: not a parameter group of caustics"):
        get("caustics")({"sky": {}})


def test_flat_water_gives_the_analytic_map():
    # Overhead sun, flat water 1 m deep, absorption a: E = exp(-a * 1).
    wh, gh = np.zeros((32, 32), np.float32), np.full((32, 32), -1.0, np.float32)
    m, stats = caustics.render(wh, gh, 0.05, (64, 64),
                               {"absorption": (0.5, 0.1, 0.0), "periodic": 1})
    for c, a in enumerate((0.5, 0.1, 0.0)):
        np.testing.assert_allclose(m[..., c], np.exp(-a), rtol=1e-5)
    np.testing.assert_allclose(stats.entered, [1.6 * 1.6] * 3, rtol=1e-6)  # E x area (float cells)


def test_volume_is_conserved_and_depth_never_negative():
    with Water({"width": 48, "height": 40, "cell_size": 0.05, "dt": 0.1, "substeps": 2}) as w:
        y, x = np.mgrid[0:40, 0:48]
        ground = (0.02 * x - 0.5).astype(np.float32)  # a slope: part of it stays dry
        w.set_ground(ground)
        w.set_surface(np.where((x - 10) ** 2 + (y - 20) ** 2 < 30, 0.1, 0.0).astype(np.float32))
        v0 = w.volume()
        for _ in range(300):
            w.step()
        assert w.volume() == pytest.approx(v0, rel=1e-9)
        assert w.depth().min() >= 0.0
        assert np.all(np.isfinite(w.surface()))


def test_cancel_leaves_the_state_as_it_was():
    with Water({"width": 32, "height": 32, "rain_rate": 200.0}) as w:
        w.set_level(0.5)
        w.step()
        before, n = w.save_state(), w.step_count()
        prog = _lib.Progress()
        prog.cancel = 1
        with pytest.raises(errors.Cancelled):
            w.step(prog)
        assert w.step_count() == n and w.save_state() == before


def test_checkpoint_resumes_bit_for_bit():
    params = {"width": 32, "height": 32, "rain_rate": 100.0, "seed": 7}
    with Water(params) as a, Water(params) as b:
        a.set_level(0.5)
        for _ in range(5):
            a.step()
        b.load_state(a.save_state())
        for _ in range(5):
            a.step()
            b.step()
        assert a.surface().tobytes() == b.surface().tobytes()


def test_effect_bytes_do_not_depend_on_threads(tmp_path):
    files = {}
    for threads in (1, 2):
        e = get("caustics")({"water": {"width": 48, "height": 48, "rain_rate": 60.0,
                                       "threads": threads},
                             "light": {"threads": threads, "light_direction": (0.2, 0.1, 1)}},
                            {"map_size": (96, 96)})
        BakeRunner(e, tmp_path / str(threads), 1, 4).run()
        e.close()
        files[threads] = [(tmp_path / str(threads) / f"caustics_{i:04d}.exr").read_bytes()
                          for i in range(1, 5)]
    assert files[1] == files[2]


def test_a_closed_handle_refuses_calls():
    w = Water()
    w.close()
    with pytest.raises(errors.StateError, match="closed"):
        w.step()


def cut_and_resume(params, inputs, folder, end, cut, every):
    """Bakes frames 1..end of caustics into ``folder``, cancelled after frame ``cut``, then
    resumed to the end (a checkpoint every ``every`` frames)."""
    e = get("caustics")(params, inputs)
    r = BakeRunner(e, folder, 1, end, checkpoint_every=every,
                   on_frame=lambda s: s.frame == cut and r.cancel())
    with pytest.raises(errors.Cancelled):
        r.run()
    e.close()
    e = get("caustics")(params, inputs)
    BakeRunner(e, folder, 1, end, checkpoint_every=every, resume=True).run()
    e.close()


def test_loop_is_seamless_and_resumes(tmp_path):
    """The frame after the last of a loop is the first again: the last frame's height field
    continues into the first as smoothly as two neighbouring frames do."""
    params = {"water": {"width": 32, "height": 32, "rain_rate": 120.0, "seed": 5}}
    inputs = {"map_size": (64, 64), "loop": (1, 16, 6)}
    e = get("caustics")(params, inputs)
    BakeRunner(e, tmp_path / "a", 1, 16, checkpoint_every=4).run()
    e.close()
    from hydrobake.core import exr
    h = [exr.read(tmp_path / "a" / f"water_{i:04d}.exr")["height"] for i in range(1, 17)]
    # The last frame is exactly the state one step before the first: the pre-roll's end.
    with Water(params["water"]) as w:
        w.set_level(0.5)
        for _ in range(6):
            w.step()
        np.testing.assert_array_equal(h[15], w.surface())
        w.step()
        np.testing.assert_array_equal(h[0], w.surface())
    steps = [np.abs(h[i + 1] - h[i]).mean() for i in range(15)]
    wrap = np.abs(h[0] - h[15]).mean()
    assert wrap <= 1.5 * max(steps), (wrap, steps)  # the seam is an ordinary step
    # Resuming mid-loop keeps the pre-roll: same bytes.
    cut_and_resume(params, inputs, tmp_path / "c", 16, 9, 4)
    for i in range(1, 17):
        assert (tmp_path / "a" / f"caustics_{i:04d}.exr").read_bytes() == \
            (tmp_path / "c" / f"caustics_{i:04d}.exr").read_bytes()
    with pytest.raises(errors.InvalidArgument, match="loop blend = 16"):
        get("caustics")(params, {"loop": (1, 16, 16)})
    with pytest.raises(errors.InvalidArgument, match=r"^loop = frames 5\.\.5: a loop needs at "
                       "least 2 frames"):  # not "loop blend = 1: must be in [1, 0]"
        get("caustics")(params, {"loop": (5, 5, 1)})


def test_view_image_shows_the_lit_ground_and_reflects_the_sky():
    """Flat water seen from straight above: no refraction shift, so each sample shows the lit
    ground below it, times the Fresnel transmittance; the sky comes in at R = ((n-1)/(n+1))^2."""
    n = 32
    wh, gh = np.zeros((n, n), np.float32), np.full((n, n), -1.0, np.float32)
    cell = 0.05
    tex = np.zeros((n, n, 3), np.float32)
    tex[..., 0] = np.linspace(0, 1, n)[None, :]  # a red ramp along x
    cmap = np.ones((n, n, 4), np.float32)
    sky = np.full((8, 16, 3), 2.0, np.float32)
    centre = (n * cell / 2, n * cell / 2, 1000.0)  # far above: rays nearly vertical
    img = caustics.view_image(wh, gh, cell, centre, tex, cmap, sky, {"fresnel": 1})
    r0 = ((1.333 - 1) / (1.333 + 1)) ** 2
    mid = n // 2
    np.testing.assert_allclose(img[mid, :, 0], (1 - r0) * tex[mid, :, 0] + r0 * 2.0, atol=2e-3)
    np.testing.assert_allclose(img[mid, :, 1], r0 * 2.0, atol=2e-3)
    # A brighter caustic map brightens the ground in proportion.
    img2 = caustics.view_image(wh, gh, cell, centre, tex, cmap * 2, None, {"fresnel": 1})
    np.testing.assert_allclose(img2[mid, 4:-4, 0], 2 * (1 - r0) * tex[mid, 4:-4, 0], atol=2e-3)
    # A NaN or infinite texel came out as such in the image: refused by pixel, in the sky as
    # in the ground texture and the map (checked by the library's lit ground).
    for name, arr, at, want in (("environment", sky, (3, 5, 1), "environment at pixel (5, 3)"),
                                ("texture", tex, (2, 7, 0), "texture at pixel (7, 2)"),
                                ("map", cmap, (4, 1, 2), "caustics at pixel (1, 4)")):
        bad = arr.copy()
        bad[at] = np.inf if name != "texture" else np.nan
        got = [sky, tex, cmap]
        got[("environment", "texture", "map").index(name)] = bad
        with pytest.raises(errors.InvalidArgument, match=re.escape(want)):
            caustics.view_image(wh, gh, cell, centre, got[1], got[2], got[0], {"fresnel": 1})


def test_view_image_looks_up_the_sky_in_the_world_for_a_turned_grid():
    """A grid turned by ``heading`` about z sees the sky turned back: the camera looks along
    the grid's x, which is the sky's x at heading 0 (red there) and its y at a quarter turn
    (blue there); a whole turn is no turn."""
    n = 32
    wh, gh = np.zeros((n, n), np.float32), np.full((n, n), -1.0, np.float32)
    cell = 0.05
    tex, cmap = np.zeros((n, n, 3), np.float32), np.ones((n, n, 4), np.float32)
    sky = np.zeros((16, 64, 3), np.float32)
    lon = ((np.arange(64) + 0.5) / 64 - 0.5) * 360.0
    sky[:, np.abs(lon) < 45, 0] = 1.0
    sky[:, np.abs(lon) >= 45, 2] = 1.0
    camera = (-2.0, n * cell / 2, 0.5)  # low, looking over the water along +x
    red, blue = [], []
    for heading in (0.0, np.pi / 2, 2 * np.pi):
        img = caustics.view_image(wh, gh, cell, camera, tex, cmap, sky, {"fresnel": 1},
                                  heading=heading)
        red.append(img[..., 0].mean())
        blue.append(img[..., 2].mean())
    assert red[0] > 5 * blue[0] and blue[1] > 5 * red[1], (red, blue)
    np.testing.assert_allclose([red[2], blue[2]], [red[0], blue[0]], rtol=1e-5)


def test_effect_bakes_the_view_preview(tmp_path):
    tex = np.full((16, 16, 3), 0.5, np.float32)
    e = get("caustics")({"water": {"width": 24, "height": 24, "rain_rate": 50.0}},
                        {"map_size": (48, 48), "view": {"camera": (0.3, -0.5, 2.0),
                                                        "texture": tex, "environment": None}})
    BakeRunner(e, tmp_path, 1, 2).run()
    e.close()
    from hydrobake.core import exr
    v = exr.read(tmp_path / "view_0002.exr")
    assert set(v) == {"R", "G", "B"} and v["R"].shape == (24, 24)
    assert 0.2 < float(v["G"].mean()) < 0.6  # grey ground, mostly transmitted


def test_workspace_keeps_scratch_and_changes_no_byte():
    y, x = np.mgrid[0:40, 0:48]
    wh = (0.01 * np.sin(x * 0.4) * np.cos(y * 0.3)).astype(np.float32)
    gh = np.where(x > 30, 0.02 * (x - 30) - 0.3, -0.3).astype(np.float32)  # a beach
    params = {"light_direction": (0.3, 0.1, 1.0), "ior": (1.33, 1.333, 1.34)}
    with caustics.Workspace() as ws:
        assert ws.nbytes == 0
        for size in ((96, 80), (200, 160), (64, 48)):
            ref, ref_stats = caustics.render(wh, gh, 0.05, size, params)
            got, stats = caustics.render(wh, gh, 0.05, size, params, workspace=ws)
            assert ref.tobytes() == got.tobytes()
            assert ref_stats.as_dict() == stats.as_dict()
            assert ws.nbytes > 0
    with pytest.raises(errors.StateError, match="closed"):
        caustics.render(wh, gh, 0.05, (8, 8), workspace=ws)


def test_oblique_sun_is_bent_by_snells_law_per_channel():
    # Flat water 1 m deep, the sun 60 deg from the zenith towards +x, not periodic: light
    # lands D tan(theta_r) towards -x of where it entered (sin theta = n sin theta_r), so the
    # map is E cos(theta) up to Lx - D tan(theta_r) and dark beyond; each channel's index
    # gives its own edge (dispersion), along the map's x (columns).
    n_x, lx = 80, 2.0
    wh, gh = np.zeros((8, n_x), np.float32), np.full((8, n_x), -1.0, np.float32)
    iors = (1.331, 1.333, 1.337)
    light = (np.float32(np.tan(np.radians(60.0))), 0.0, 1.0)
    m, _ = caustics.render(wh, gh, lx / n_x, (400, 4),
                           {"light_direction": light, "ior": iors})
    sin_t = float(light[0]) / np.hypot(float(light[0]), 1.0)
    cos_t = 1.0 / np.hypot(float(light[0]), 1.0)
    x0 = np.arange(400) * lx / 400
    for c, n in enumerate(iors):
        sr = sin_t / np.float32(n)
        edge = lx - sr / np.sqrt(1.0 - sr * sr)
        want = cos_t * np.clip((edge - x0) / (lx / 400), 0.0, 1.0)
        for row in m[..., c]:
            np.testing.assert_allclose(row, want, atol=1e-5)


def test_a_rising_floor_lifts_the_water_and_keeps_its_volume(tmp_path):
    """An animated Ground (ground_path): from frame 3 a block of the floor stands 0.2 m
    higher. The water keeps its depth over it, so the volume is unchanged, the mean surface
    rises by the block's mean height exactly, the caustics change, and a bake cancelled
    before the rise resumes to the same bytes as one that never stopped."""
    params = {"water": {"width": 32, "height": 24, "rain_rate": 0.0, "seed": 2}}
    raised = np.zeros((24, 32), np.float32)
    raised[8:16, 10:20] = 0.2
    inputs = {"map_size": (64, 48), "level": 0.5, "ground_path": {3: raised}}
    from hydrobake.core import exr
    runs = {}
    for name, inp in (("flat", {"map_size": (64, 48), "level": 0.5}), ("rising", inputs)):
        e = get("caustics")(params, inp)
        BakeRunner(e, tmp_path / name, 1, 5, checkpoint_every=1).run()
        e.close()
        runs[name] = [exr.read(tmp_path / name / f"water_{i:04d}.exr") for i in range(1, 6)]
    w = runs["rising"]
    for f in range(5):
        assert w[f]["depth"].astype(np.float64).sum() == pytest.approx(
            w[0]["depth"].astype(np.float64).sum(), rel=1e-6)
    rise = w[2]["height"].astype(np.float64).mean() - w[1]["height"].astype(np.float64).mean()
    assert rise == pytest.approx(raised.mean(), rel=1e-4), rise
    assert np.ptp(w[2]["height"]) > 0.05  # (a mound over the block, spreading as waves)
    for f in (0, 1):  # the same water until the floor moves
        assert w[f]["height"].tobytes() == runs["flat"][f]["height"].tobytes()
    read = [(tmp_path / n / "caustics_0004.exr").read_bytes() for n in ("flat", "rising")]
    assert read[0] != read[1]
    # cancelled after frame 2, resumed: the same files
    cut_and_resume(params, inputs, tmp_path / "cut", 5, 2, 1)
    for i in range(1, 6):
        for s in ("caustics", "water"):
            assert (tmp_path / "rising" / f"{s}_{i:04d}.exr").read_bytes() == \
                (tmp_path / "cut" / f"{s}_{i:04d}.exr").read_bytes(), (s, i)
    with pytest.raises(ValueError, match=r"^ground_path\[3\]: shape \(24, 31\) must match the "
                       r"water grid \(24, 32\)"):
        get("caustics")(params, {"ground_path": {3: raised[:, :31]}})


def test_a_moving_source_pours_where_it_is_each_frame(tmp_path):
    """sources_path: the tap pours at its first place over frames 1-2, then 3 cells along;
    each frame's volume grows by exactly what its own sources pour, and the water first
    rises under the new place at frame 3."""
    params = {"water": {"width": 32, "height": 24, "rain_rate": 0.0, "dt": 0.05}}
    tap = np.zeros((24, 32), np.float32)
    tap[10:13, 5:8] = 0.4
    moved = np.roll(tap, 12, axis=1)
    e = get("caustics")(params, {"map_size": (64, 48), "level": 0.5, "sources": tap,
                                 "sources_path": {3: moved}})
    BakeRunner(e, tmp_path / "tap", 1, 4).run()
    e.close()
    from hydrobake.core import exr
    w = [exr.read(tmp_path / "tap" / f"water_{i:04d}.exr") for i in range(1, 5)]
    vol = [float(x["depth"].astype(np.float64).sum()) for x in w]
    per_frame = float(tap.astype(np.float64).sum()) * 0.05  # both places pour as much
    base = 0.5 * 24 * 32
    assert vol[0] - base == pytest.approx(per_frame, rel=1e-4)
    for a, b in zip(vol, vol[1:]):
        assert b - a == pytest.approx(per_frame, rel=1e-4)
    under = [float(x["height"][10:13, 17:20].mean()) for x in w]
    # a tenth of the 2 cm a frame pours there stays over it (5 mm here; 0.2 mm from the
    # first place's waves alone)
    assert under[2] - under[1] > 0.1 * 0.4 * 0.05, under
    with pytest.raises(ValueError, match=r"^sources_path\[2\]: shape \(23, 32\)"):
        get("caustics")(params, {"sources_path": {2: tap[:23]}})
    bad = tap.copy()
    bad[4, 6] = np.nan
    with pytest.raises(ValueError, match=r"^sources_path\[3\]\[4, 6\] = nan: must be a finite "
                       r"number in \[-1000, 1000\] m/s$"):
        get("caustics")(params, {"sources_path": {3: bad}})
    bad[4, 6] = 2e6
    with pytest.raises(ValueError, match=r"^ground_path\[2\]\[4, 6\] = 2e\+06: must be a "
                       r"finite number in \[-1e\+06, 1e\+06\] m$"):
        get("caustics")(params, {"ground_path": {2: bad}})
