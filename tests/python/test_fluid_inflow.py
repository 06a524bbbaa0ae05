"""The fluid's inflow through the binding and the core effect: refusals by name, the rate it
pours at, a tap turned on and off by frame, what a resume compares, and a bake cut and
resumed giving the same bytes as one that was not."""
import numpy as np
import pytest

from hydrobake.core import errors, fluid
from hydrobake.core.bake import BakeRunner
from hydrobake.core.effects import get
from test_fluid_binding import grid_values

# The 1 m box at 16^3 (spacing 2 cm), no gravity, little viscosity: a jet keeps its speed.
STILL = {"resolution": (16, 16, 16), "gravity": (0.0, 0.0, 0.0), "viscosity": 0.01,
         "max_particles": 4000, "threads": 1}
# A tap across x: one lattice point thick (x 0.195), 4 x 4 points in y and z (0.465..0.525);
# its bounds lie half a spacing off the lattice, so rounding cannot add or drop a row.
TAP = ("box", (0.2, 0.5, 0.5), (0.015, 0.045, 0.045))
POINTS, S, DT = 16, 0.02, 1 / 24


def test_set_inflow_refusals_name_themselves_and_leave_the_tap():
    with fluid.Fluid(dict(STILL, max_particles=100)) as f:
        f.set_inflow(TAP, (1.0, 0.0, 0.0))
        for shape, kw, want in (
                (("sphere", (0.5, 0.5), 0.1), {}, r"^shape\.centre: must have 3 numbers"),
                (("cone", (0.5, 0.5, 0.5), 0.1), {}, r"^shape\.kind"),
                (("turned_box", (0.5, 0.5, 0.5), (0.1, 0.1, 0.1), (2, 0, 0, 0)), {},
                 r"^shape\.rotation: length 2, must be a unit quaternion"),
                (("mesh", (0.5, 0.5, 0.5), (0.1, 0.1, 0.1), (1, 0, 0, 0), None), {},
                 r"^shape\.field: must be an array"),
                (TAP, {"velocity": (1.0, 2.0)}, r"^velocity: must have 3 numbers, got 2"),
                (TAP, {"velocity": (float("nan"), 0, 0)},
                 r"^velocity\[0\] = nan: must be a finite number in \[-1000, 1000\] m/s"),
                (TAP, {"velocity": (0, 2000, 0)},
                 r"^velocity\[1\] = 2000: must be a finite number in \[-1000, 1000\] m/s"),
                (TAP, {"jitter": 0.7}, r"^jitter = 0\.7: must be in \[0, 0\.5\]"),
                # 5 x 5 x 5 lattice points at once, more than max_particles
                (("box", (0.5, 0.5, 0.5), (0.055, 0.055, 0.055)), {},
                 r"^inflow: the shape holds 125 particles at once: must hold at most "
                 r"max_particles = 100")):
            with pytest.raises(errors.InvalidArgument, match=want):
                f.set_inflow(shape, **kw)
        # still the first tap: whole rows of its 16 points (see the rate)
        f.step()
        poured, capped = f.inflow_added
        assert poured >= 2 * POINTS and poured % POINTS == 0 and not capped
        f.set_inflow(None)  # stops it
        f.step()
        assert f.inflow_added == (0, False) and f.particle_count == poured
    with fluid.Fluid(dict(STILL, source="PARTICLES")) as f:
        with pytest.raises(errors.InvalidArgument, match=r"^inflow: source = 1: only the "
                                                         r"simulation \(0\) pours an inflow"):
            f.set_inflow(TAP, (1.0, 0.0, 0.0))


def test_the_tap_pours_k2_v_dt_over_spacing_a_frame():
    """16 points at 1 m/s: a row every s / v = 20 ms, 33.3 particles a 1/24 s frame, give or
    take the row a frame's end can cut over 7 frames (a point pours at a substep's start once
    the particle before has gone a spacing, the new one as far along as if it had left then:
    the rows stay a spacing apart). Every particle moves at v within 0.1% (the jet's middle is
    a lattice at rest density: its rounding leaves a little pressure), on the tap's rows
    downstream of it."""
    with fluid.Fluid(STILL) as f:
        f.set_inflow(TAP, (1.0, 0.0, 0.0))
        counts, substeps = [], set()
        for _ in range(8):
            before = f.particle_count
            f.step()
            added, capped = f.inflow_added
            assert added == f.particle_count - before and not capped
            counts.append(f.particle_count)
            substeps.add(f.substeps_taken)
        per_frame = (counts[-1] - counts[0]) / 7
        want = POINTS * 1.0 * DT / S
        assert len(substeps) == 1  # (equal frames)
        assert abs(per_frame - want) <= POINTS / 7, (per_frame, want)
        pos, vel = f.particles()
        np.testing.assert_allclose(vel, np.tile((1.0, 0.0, 0.0), (len(vel), 1)), atol=1e-3)
        rows = (pos[:, 1:] - 0.465) / S
        np.testing.assert_allclose(rows, np.round(rows), atol=1e-3)
        assert rows.min() > -0.5 and rows.max() < 3.5 and pos[:, 0].min() >= 0.195 - 1e-6


@pytest.mark.parametrize("velocity, columns", [
    ((1.0, 0.0, 0.0), 16), ((0.0, -2.0, 0.0), 4), ((0.0, 0.0, 0.5), 4), ((0.0, 0.0, 0.0), 0)])
def test_the_inflow_rate_is_its_columns_along_the_flow_times_speed_over_spacing(velocity,
                                                                               columns):
    """The tap is 1 x 4 x 4 points (x, y, z): 16 columns across x, 4 across y or z."""
    with fluid.Fluid(STILL) as f:
        assert f.inflow_rate == 0.0
        f.set_inflow(TAP, velocity)
        assert f.inflow_rate == pytest.approx(columns * float(np.linalg.norm(velocity)) / S)
        f.set_inflow(None)
        assert f.inflow_rate == 0.0


def test_a_tilted_tap_pours_as_much_as_a_straight_one():
    """A ball of water at 1 m/s pours its rate (columns x v / s a second) whichever way it
    points: its points are laid along the flow, so each column leaves a row a spacing apart.
    Over 8 frames after the first, within the one row a frame's end can cut; its columns within
    15% of its cross-section's (the lattice rounds a small ball's edge). (On the world's lattice
    a diagonal stream passed near the points beside its own: about 40% of the water.)"""
    ball = ("sphere", (0.5, 0.5, 0.5), 0.08)
    for d in ((0.0, 0.0, -1.0), (0.0, 0.6, -0.8), (-0.577350, 0.577350, -0.577350)):
        with fluid.Fluid(STILL) as f:
            f.set_inflow(ball, d)
            rate = f.inflow_rate
            f.step()
            first = f.particle_count
            for _ in range(8):
                f.step()
            got = f.particle_count - first
            assert abs(got - rate * 8 * DT) <= rate * S + 1e-6, (d, got, rate)
            # its columns: the cross-section's pi r^2 / s^2 (50.3), as the lattice rounds it
            assert abs(rate * S - np.pi * 0.08 ** 2 / S ** 2) < 0.15 * 50.3, (d, rate)


def tap_effect(inflow, velocity=(1.0, 0.0, 0.0), fluid_params=STILL, **inputs):
    return get("fluid")({"fluid": fluid_params},
                        dict(inputs, inflow=inflow, inflow_velocity=velocity))


def test_a_tap_turned_on_at_frame_3_and_off_at_6_pours_in_frames_3_to_5_only():
    e = tap_effect({3: TAP, 6: None}, fill=((0.6, 0.6, 0.0), (0.8, 0.8, 0.1)))
    try:
        counts = [e.fluid.particle_count]
        for frame in range(1, 10):
            e.step(frame, None)
            assert e.fluid.inflow_added[0] == e.fluid.particle_count - counts[-1]
            counts.append(e.fluid.particle_count)
        added = dict(zip(range(1, 10), np.diff(counts)))
        assert {f: n for f, n in added.items() if f not in (3, 4, 5)} == \
            {1: 0, 2: 0, 6: 0, 7: 0, 8: 0, 9: 0}
        # whole rows, a spacing apart: 33.3 a frame, give or take a row
        assert all(added[f] % POINTS == 0 and abs(added[f] - POINTS * DT / S) <= POINTS
                   for f in (3, 4, 5)), added
        assert abs(sum(added[f] for f in (3, 4, 5)) - 3 * POINTS * DT / S) <= POINTS, added
    finally:
        e.close()


def forecast_and_stop(e, last, step=True):
    """(the frame the forecast of frames 1..last names, the frame a bake of them then stops
    pouring at: None if it does not, or not ``step``)."""
    (text,) = e.forecast(1, last)
    said = int(text.split("about frame ")[1].split()[0])
    for frame in range(1, last + 1 if step else 1):
        e.step(frame, None)
        if e.fluid.inflow_added[1]:
            return said, frame
    return said, None


def test_the_forecast_names_the_frame_the_inflow_will_stop_at():
    """A ball under gravity pouring down and sideways from frame 3 (turned off at 40, on again
    at 45) onto a pool, with room for 3000 more particles: the forecast's frame is the bake's
    own stop within a frame, and it leaves the effect as it was (the same particles, stepped,
    as a twin never asked). With room for the whole bake, or an outflow open by then, it says
    nothing; an outflow opened after it does not change it."""
    params = dict(STILL, gravity=(0.0, 0.0, -9.81), max_particles=5000)
    pool = ((0.0, 0.0, 0.0), (0.4, 0.4, 0.1))
    ball = ("sphere", (0.6, 0.5, 0.7), 0.06)
    flow = {3: ball, 40: None, 45: ball}

    def effect(**kw):
        return tap_effect(flow, (0.6, 0.0, -0.8), params, fill=pool, **kw)
    e, twin = effect(), effect()
    try:
        said = e.forecast(1, 80)
        assert len(said) == 1 and said[0].startswith(
            "the inflow will stop pouring at about frame "), said
        assert "onto the 2000 the fluid starts with, it reaches max_particles = 5000" in said[0]
        foretold = int(said[0].split("about frame ")[1].split(" ")[0])
        stopped = None
        for frame in range(1, 81):
            e.step(frame, None)
            twin.step(frame, None)
            if frame == 10:
                assert np.array_equal(e.fluid.particles()[0], twin.fluid.particles()[0])
            if e.fluid.inflow_added[1]:
                stopped = frame
                break
        assert stopped is not None and abs(foretold - stopped) <= 1, (said, stopped)
    finally:
        e.close()
        twin.close()
    drain = ("box", (0.9, 0.5, 0.05), (0.1, 0.5, 0.05))
    for end, kw in ((foretold - 2, {}), (80, {"outflow": {1: drain}}),
                    (80, {"outflow": {1: None, foretold: drain}})):
        e = effect(**kw)
        try:
            assert e.forecast(1, end) == [], kw
        finally:
            e.close()
    e = effect(outflow={1: None, foretold + 3: drain})  # (opened after the stop: said)
    try:
        now = e.forecast(1, 80)
        assert now[0].split("; to pour")[0] == said[0].split("; to pour")[0], (now, said)
        assert now[0].endswith(f"to pour until the outflow opens at frame {foretold + 3}, raise "
                               "it to about 6000, or add an outflow to drain the water sooner")
    finally:
        e.close()


def test_inflow_inputs_are_checked_by_name():
    fill = ((0.6, 0.6, 0.0), (0.8, 0.8, 0.1))
    for inflow, velocity, want in (
            ({1: TAP}, (1.0, 2.0), r"^inflow_velocity: must have 3 numbers, got 2"),
            ({1: TAP}, (2000.0, 0.0, 0.0),
             r"^inflow_velocity = \(2000, 0, 0\): each component must be a finite number in "
             r"\[-1000, 1000\] m/s"),
            ({1: TAP}, (float("nan"), 0.0, 0.0), r"^inflow_velocity = \(nan, 0, 0\): each "),
            ({1: TAP}, "fast", r"^inflow_velocity"),
            (TAP, (1.0, 0.0, 0.0), r"^inflow: tuple: must be a dict \{frame: shape or None\}"),
            ([TAP], (1.0, 0.0, 0.0),  # (a list is of taps, each {frame: shape})
             r"^inflow\[0\]: tuple: must be a dict \{frame: shape or None\}"),
            ({3: ("sphere", (0.5, 0.5), 0.1)}, (1.0, 0.0, 0.0),
             r"^inflow\[3\]\.centre: must have 3 numbers")):
        with pytest.raises(errors.InvalidArgument, match=want):
            tap_effect(inflow, velocity, fill=fill)
    # a shape no particle fits in at any frame (outside the box, or thinner than the
    # lattice) pours nothing: refused; outside at one frame only, it pours nothing there
    with pytest.raises(errors.InvalidArgument, match=r"^inflow: no particle fits inside its "
                                                     r"shape at any frame, within the box"):
        tap_effect({1: ("sphere", (1.5, 0.5, 0.5), 0.1), 3: ("sphere", (0.5, 0.5, 0.5), 0.004)},
                   fill=fill)
    e = tap_effect({1: ("sphere", (1.5, 0.5, 0.5), 0.1), 3: TAP}, fill=fill)
    try:
        n0 = e.fluid.particle_count
        for frame in (1, 2):
            e.step(frame, None)
        assert e.fluid.particle_count == n0
        e.step(3, None)
        assert e.fluid.particle_count > n0
    finally:
        e.close()
    # the library's own check of each shape, before the first frame (not at the frame it
    # pours from, which would stop a bake halfway)
    with pytest.raises(errors.InvalidArgument, match=r"^inflow\[2\]: the shape holds 3375 "
                                                     r"particles at once: must hold at most "
                                                     r"max_particles = 100"):
        tap_effect({1: None, 2: ("box", (0.5, 0.5, 0.5), (0.15, 0.15, 0.15))},
                   fluid_params=dict(STILL, max_particles=100),
                   fill=((0.6, 0.6, 0.0), (0.7, 0.7, 0.04)))


def test_a_velocity_given_by_frame_turns_the_stream():
    """inflow_velocity {1: +x, 4: +y} (a hose that turns at frame 4): the water poured in
    frames 1-3 leaves along x, that of frames 4-6 along y, each at 1 m/s within 2%; what a
    resume compares is the velocity at each frame (not one for the bake)."""
    turn = {1: (1.0, 0.0, 0.0), 4: (0.0, 1.0, 0.0)}
    e = tap_effect({1: TAP}, velocity=turn)
    try:
        for frame in range(1, 7):
            before = e.fluid.particle_count
            e.step(frame, None)
            _, vel = e.fluid.particles()
            new = vel[before:]
            assert len(new) > 0, frame  # (fewer along y: the tap is 4 points deep that way)
            want = np.float32(turn[1 if frame < 4 else 4])
            assert np.all(np.abs(new - want) < 0.02), (frame, new[np.argmax(
                np.abs(new - want).max(axis=1))])
        assert "inflow velocity" not in e.scalar_inputs()
        got = [e.frame_inputs(f)["inflow velocity"] for f in (1, 3, 4, 9)]
        assert got[0] == got[1] != got[2] == got[3], got
    finally:
        e.close()
    # before its first key, a velocity by frame holds its first value
    e = tap_effect({1: TAP}, velocity={3: (0.0, 0.0, 1.0)})
    try:
        e.step(1, None)
        assert np.all(np.abs(e.fluid.particles()[1] - np.float32([0, 0, 1])) < 0.02)
    finally:
        e.close()
    for velocity, want in (
            ({3: (1.0, 2.0)}, r"^inflow_velocity\[3\]: must have 3 numbers, got 2"),
            ({1: (1.0, 0.0, 0.0), 3: (2000.0, 0.0, 0.0)},
             r"^inflow_velocity\[3\] = \(2000, 0, 0\): each component must be a finite "
             r"number in \[-1000, 1000\] m/s"),
            ({}, r"^inflow_velocity: \{\}: must give a velocity for at least one frame")):
        with pytest.raises(errors.InvalidArgument, match=want):
            tap_effect({1: TAP}, velocity=velocity)


@pytest.mark.parametrize("source", ["PARTICLES", "VELOCITY_GRID"])
def test_an_inflow_is_refused_for_another_source(source):
    with pytest.raises(errors.InvalidArgument, match=r"^inflow: only the simulation \(source "
                                                     r"SIMULATE\) pours an inflow"):
        tap_effect({1: TAP}, fluid_params=dict(STILL, source=source))


def test_what_a_resume_compares_names_the_tap_and_its_velocity():
    """The frame's inputs carry the shape poured from at that frame (None's digest before and
    after), the scalar inputs the velocity; neither is there without an inflow."""
    moved = ("box", (0.25, 0.5, 0.5), TAP[2])
    a = tap_effect({3: TAP, 6: None})
    b = tap_effect({3: moved, 6: None})
    c = tap_effect({3: TAP, 6: None}, velocity=(2.0, 0.0, 0.0))
    plain = get("fluid")({"fluid": STILL}, {"fill": ((0.6, 0.6, 0.0), (0.8, 0.8, 0.1))})
    try:
        ins = {f: a.frame_inputs(f)["inflow"] for f in range(1, 9)}
        assert ins[1] == ins[2] == ins[6] == ins[8] != ins[3] == ins[4] == ins[5]
        for f in (1, 2, 6, 7):
            assert b.frame_inputs(f)["inflow"] == ins[f]
        for f in (3, 4, 5):
            assert b.frame_inputs(f)["inflow"] != ins[f]
            assert c.frame_inputs(f)["inflow"] == ins[f]
        assert a.scalar_inputs()["inflow velocity"] == [1.0, 0.0, 0.0]
        assert c.scalar_inputs()["inflow velocity"] == [2.0, 0.0, 0.0]
        assert "inflow velocity" not in plain.scalar_inputs()
        assert "inflow" not in plain.frame_inputs(3)
    finally:
        for e in (a, b, c, plain):
            e.close()
    # a mesh tap: its field is part of the digest
    field = np.full((4, 4, 4), -0.01, np.float32)
    mesh = ("mesh", (0.2, 0.5, 0.5), (0.015, 0.045, 0.045), (1.0, 0.0, 0.0, 0.0), field)
    d = tap_effect({3: mesh})
    e = tap_effect({3: mesh[:4] + (field * 2,)})
    try:
        assert d.frame_inputs(3)["inflow"] != e.frame_inputs(3)["inflow"]
        assert d.frame_inputs(2)["inflow"] == e.frame_inputs(2)["inflow"]
    finally:
        d.close()
        e.close()


POOL = dict(STILL, gravity=(0.0, 0.0, -9.81), substeps=8)


def baked(inputs, folder, end, resume=False, params=POOL):
    """Bakes frames 1..end of a fluid of ``params`` with ``inputs`` into ``folder`` (a
    checkpoint every two frames); returns the runner and the particles' bytes at the end."""
    e = get("fluid")({"fluid": params}, inputs)
    try:
        r = BakeRunner(e, folder, 1, end, checkpoint_every=2, resume=resume)
        r.run()
        pos, vel = e.fluid.particles()
        return r, pos.tobytes() + vel.tobytes()
    finally:
        e.close()


def pour(folder, end, resume=False, tap=TAP, velocity=(1.0, 0.0, -0.5), normal=0.0):
    """Bakes frames 1..end of a jittered tap pouring into a pool from frame 3 to 5;
    returns the runner and the particles' bytes at the end."""
    return baked({"fill": ((0.3, 0.3, 0.0), (0.7, 0.7, 0.06)), "jitter": 0.2,
                  "inflow": {3: tap, 6: None}, "inflow_velocity": velocity,
                  "inflow_normal": normal}, folder, end, resume)


def assert_resumed_alike(tmp_path, pour):
    """A bake of frames 1-8 by ``pour(folder, end, resume)`` cut after frame 4 and resumed
    has the same particles and the same files as one that was not cut."""
    _, whole = pour(tmp_path / "a", 8)
    pour(tmp_path / "b", 4)
    r, resumed = pour(tmp_path / "b", 8, resume=True)
    assert r.resumed_from == 4
    assert resumed == whole
    for i in range(1, 9):
        name = f"surface_{i:04d}.npz"
        assert (tmp_path / "a" / name).read_bytes() == (tmp_path / "b" / name).read_bytes()
        assert grid_values(tmp_path / "a" / f"fluid_{i:04d}.vdb") == \
            grid_values(tmp_path / "b" / f"fluid_{i:04d}.vdb")


def test_a_bake_cut_while_pouring_and_resumed_gives_the_same_bytes(tmp_path):
    assert_resumed_alike(tmp_path, pour)  # (cut with the tap on)


def test_a_bake_with_a_velocity_by_frame_resumes_alike_and_not_with_another(tmp_path):
    """A tap turning at frame 5 (inflow_velocity by frame, as Local Velocity gives it): the
    bake's manifest takes each frame's velocity, a cut bake resumes to the same bytes, and
    one whose velocity changed from frame 5 on is refused there."""
    turn = {1: (1.0, 0.0, -0.5), 5: (0.0, 1.0, -0.5)}

    def turning(folder, end, resume=False):
        return pour(folder, end, resume, velocity=turn)
    assert_resumed_alike(tmp_path, turning)
    pour(tmp_path / "c", 6, velocity=turn)
    with pytest.raises(errors.StateError, match=r"^cannot resume the bake in .*: inflow "
                                                r"velocity at frame 5: changed since the bake"):
        pour(tmp_path / "c", 8, resume=True, velocity={1: turn[1], 5: (0.0, 2.0, -0.5)})
    # another tap is another bake: refused at the first frame it pours
    pour(tmp_path / "c", 4)
    with pytest.raises(errors.StateError, match=r"^cannot resume the bake in .*: inflow at "
                                                r"frame 3: changed since the bake"):
        pour(tmp_path / "c", 8, resume=True, tap=("box", (0.25, 0.5, 0.5), TAP[2]))
