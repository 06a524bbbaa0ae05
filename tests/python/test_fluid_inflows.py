"""Several inflows (taps) through the binding and the core effect: added taps pour exactly what
each pours alone, at the sum of their rates; a list of schedules turns each on and off at its
own frames with its own velocity; refusals name the tap; the forecast sums them; a bake cut
while two pour resumes to the same bytes."""
import numpy as np
import pytest

from hydrobake.core import errors, fluid
from hydrobake.core.effects import get
from test_fluid_inflow import (POOL, STILL, TAP, assert_resumed_alike, baked,
                               forecast_and_stop)

TAP_B = ("box", (0.7, 0.3, 0.6), (0.045, 0.045, 0.015))
VEL_A, VEL_B = (1.0, 0.0, 0.0), (0.0, 0.5, -1.0)


def test_added_taps_pour_their_sum_and_are_refused_by_name():
    with fluid.Fluid(STILL) as f:
        f.set_inflow(TAP, VEL_A)
        a, ra = f.inflow_points, f.inflow_rate
        f.set_inflow(TAP_B, VEL_B)
        b, rb = f.inflow_points, f.inflow_rate
        f.add_inflow(TAP, VEL_A)
        assert f.inflow_points == a + b
        assert f.inflow_rate == pytest.approx(ra + rb, rel=1e-12)
        for shape, vel, normal, want in (
                (None, VEL_A, 0.0, r"^shape"),
                (TAP, (0.0, 2000.0, 0.0), 0.0, r"^velocity\[1\] = 2000: must be a finite "),
                (TAP, VEL_A, -1.0, r"^normal = -1: must be in \[0, 1000\] m/s")):
            with pytest.raises(errors.InvalidArgument, match=want):
                f.add_inflow(shape, vel, normal)
            assert f.inflow_points == a + b  # (left as they were)


def taps(inflow, velocity, fluid_params=STILL, **inputs):
    return get("fluid")({"fluid": fluid_params},
                        {"fill": ((0.3, 0.3, 0.0), (0.5, 0.5, 0.04)), "inflow": inflow,
                         "inflow_velocity": velocity, **inputs})


def test_each_tap_pours_at_its_own_frames_and_velocity():
    """Tap A from frame 1, tap B from frame 3 at its own velocity: frames 1-2 are tap A's
    bake alone, to the byte; frame 3 adds B's points moving at B's velocity."""
    two = taps([{1: TAP}, {1: None, 3: TAP_B}], [VEL_A, VEL_B])
    one = taps({1: TAP}, VEL_A)
    try:
        for frame in (1, 2):
            two.step(frame, None)
            one.step(frame, None)
        a, b = two.fluid.particles(), one.fluid.particles()
        assert a[0].tobytes() + a[1].tobytes() == b[0].tobytes() + b[1].tobytes()
        before = two.fluid.particle_count
        two.step(3, None)
        pos, vel = two.fluid.particles()
        new = np.arange(len(pos)) >= before
        near_b = np.all(np.abs(pos - TAP_B[1]) < 0.1, axis=1)
        assert (new & near_b).sum() >= 32  # (B's 32 points, at least)
        np.testing.assert_allclose(vel[new & near_b], np.tile(VEL_B, ((new & near_b).sum(), 1)),
                                   atol=0.05)
        # what a resume compares names each tap pouring
        assert two.frame_inputs(2)["inflow velocity"] != two.frame_inputs(3)["inflow velocity"]
        assert "inflow velocity" not in two.scalar_inputs()
    finally:
        two.close()
        one.close()


def test_several_taps_are_checked_by_name_alone_and_together():
    for inflow, velocity, want in (
            ([{1: TAP}, {1: TAP_B}], [VEL_A, VEL_B, VEL_A],
             r"^inflow_velocity: 3 entries for 2 inflows: must give one for each, or one for all"),
            ([{1: TAP}, {1: TAP_B}], [VEL_A, (2000.0, 0.0, 0.0)],
             r"^inflow_velocity\[1\] = \(2000, 0, 0\): each component must be a finite"),
            ([{1: TAP}, {2: ("sphere", (0.5, 0.5), 0.1)}], VEL_A,
             r"^inflow\[1\]\[2\]\.centre: must have 3 numbers"),
            ([{1: TAP}, {1: ("sphere", (1.5, 0.5, 0.5), 0.1)}], VEL_A,
             r"^inflow\[1\]: no particle fits inside its shape at any frame")):
        with pytest.raises(errors.InvalidArgument, match=want):
            taps(inflow, velocity)
    with pytest.raises(errors.InvalidArgument, match=r"^inflow_normal\[1\]\[4\] = -1: must be"):
        taps([{1: TAP}, {1: TAP_B}], VEL_A, inflow_normal=[0.0, {1: 0.0, 4: -1.0}])
    # each fits max_particles alone, not together: refused before the bake, at that frame
    big = ("box", (0.5, 0.5, 0.5), (0.1, 0.1, 0.1))  # 1000 points
    with pytest.raises(errors.InvalidArgument, match=r"^inflow\[3\]: the shapes hold 1016 "
                                                     r"particles at once: must hold at most "
                                                     r"max_particles = 1010"):
        get("fluid")({"fluid": dict(STILL, max_particles=1010)},
                     {"inflow": [{1: big}, {3: TAP}], "inflow_velocity": VEL_A})


def test_the_forecast_sums_the_taps():
    """Two taps, the second from frame 4: the forecast's frame is within two of where the
    bake stops, and sooner than with the first alone."""
    said = {}
    for name, inflow in (("one", [{1: TAP}]), ("two", [{1: TAP}, {4: TAP_B}])):
        e = taps(inflow, [VEL_A, VEL_B][:len(inflow)], fluid_params=dict(POOL, max_particles=900))
        try:
            said[name], stopped = forecast_and_stop(e, 60, step=name == "two")
            if name == "two":
                assert stopped is not None and abs(stopped - said[name]) <= 2, (stopped, said)
        finally:
            e.close()
    assert said["two"] < said["one"], said


def test_a_bake_cut_while_two_taps_pour_resumes_to_the_same_bytes(tmp_path):
    inputs = {"fill": ((0.3, 0.3, 0.0), (0.7, 0.7, 0.06)), "jitter": 0.2,
              "inflow": [{3: TAP, 6: None}, {2: TAP_B}],
              "inflow_velocity": [(1.0, 0.0, -0.5), {1: VEL_B, 4: (0.0, 0.0, -1.0)}]}
    assert_resumed_alike(tmp_path, lambda folder, end, resume=False:
                         baked(inputs, folder, end, resume))
