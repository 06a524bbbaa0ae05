"""The fluid's outflow (a drain) through the binding and the core effect: refusals by name,
exactly the particles entering its shape taken, a tap into a drain pouring for good, a drain
opened and closed by frame, what a resume compares, and a bake cut and resumed giving the
same bytes as one that was not."""
import numpy as np
import pytest

from hydrobake.core import errors, fluid
from hydrobake.core.effects import get
from test_fluid_inflow import assert_resumed_alike, baked

# The 1 m box at 16^3 (spacing 2 cm, reach 4 cm), no gravity, little viscosity.
STILL = {"resolution": (16, 16, 16), "gravity": (0.0, 0.0, 0.0), "viscosity": 0.01,
         "max_particles": 4000, "threads": 1}
POOL = dict(STILL, gravity=(0.0, 0.0, -9.81), substeps=8)
# x in (0.5, 0.7) over the whole box's y and z
DRAIN = ("box", (0.6, 0.5, 0.5), (0.1, 0.5, 0.5))
TAP = ("box", (0.2, 0.5, 0.5), (0.015, 0.045, 0.045))  # 16 points, 33 a frame at 1 m/s
FLOOR = ("box", (0.6, 0.5, 0.0), (0.3, 0.5, 0.15))  # where the tap's stream lands


def coasting(f):
    """Lone particles 10 cm apart (beyond each other's reach: they coast) at x = 0.15 ..
    0.85 in two rows, moving at 0.5 m/s along x (2.08 cm a frame); their x."""
    x = np.arange(8) * 0.1 + 0.15
    pos = np.array([(xi, y, 0.5) for y in (0.3, 0.7) for xi in x], np.float32)
    f.set_particles(pos, np.tile(np.float32([0.5, 0.0, 0.0]), (len(pos), 1)))
    return pos[:, 0]


def test_set_outflow_refusals_name_themselves_and_leave_the_drain():
    with fluid.Fluid(dict(STILL, max_particles=100)) as f:
        x0 = coasting(f)
        f.set_outflow(DRAIN)
        for shape, want in (
                (("sphere", (0.5, 0.5), 0.1), r"^shape\.centre: must have 3 numbers"),
                (("cone", (0.5, 0.5, 0.5), 0.1), r"^shape\.kind"),
                (("box", (0.5, 0.5, 0.5), (0.1, -0.1, 0.1)),
                 r"^shape\.extent\[1\] = -0\.1: must be in \[0, 1e6\] m"),
                (("turned_box", (0.5, 0.5, 0.5), (0.1, 0.1, 0.1), (2, 0, 0, 0)),
                 r"^shape\.rotation: length 2, must be a unit quaternion"),
                (("mesh", (0.5, 0.5, 0.5), (0.1, 0.1, 0.1), (1, 0, 0, 0), None),
                 r"^shape\.field: must be an array"),
                (("mesh", (0.5, 0.5, 0.5), (0.1, 0.1, 0.1), (1, 0, 0, 0),
                  np.full((2, 2, 2), np.nan, np.float32)),
                 r"^shape\.field\[0, 0, 0\] = nan: must be a finite distance")):
            with pytest.raises(errors.InvalidArgument, match=want):
                f.set_outflow(shape)
        # still the first drain: the two particles starting at 0.55 and 0.65 of each row go
        f.step()
        assert f.outflow_removed == 4 and f.particle_count == 12
        pos, vel = f.particles()
        keep = (x0 < 0.5) | (x0 > 0.7)
        assert np.allclose(pos[:, 0], x0[keep] + 0.5 / 24, atol=1e-5)  # the rest, in order
        assert np.array_equal(pos[:, 1], np.repeat(np.float32([0.3, 0.7]), 6))
        assert np.all(vel == np.float32([0.5, 0.0, 0.0]))
        f.set_outflow(None)  # stops it
        for _ in range(4):  # the particle from 0.45 reaches 0.5 on the third frame
            f.step()
            assert f.outflow_removed == 0
        assert f.particle_count == 12
    with fluid.Fluid(dict(STILL, source="PARTICLES")) as f:
        with pytest.raises(errors.InvalidArgument, match=r"^outflow: source = 1: only the "
                                                         r"simulation \(0\) drains an outflow"):
            f.set_outflow(DRAIN)


def test_a_mesh_drain_takes_its_inside_not_its_boxes_corners():
    """A sphere of 8 cm as a mesh's field in a box of 10 cm half-sizes: the row through its
    centre loses the two particles that pass within it; the row 9 cm off (inside the box,
    outside the sphere) loses none."""
    n = 33
    g = np.linspace(-0.1, 0.1, n)
    z, y, x = np.meshgrid(g, g, g, indexing="ij")
    field = (np.sqrt(x * x + y * y + z * z) - 0.08).astype(np.float32)
    with fluid.Fluid(STILL) as f:
        pos = np.array([(xi, y, 0.5) for y in (0.3, 0.39) for xi in np.arange(8) * 0.1 + 0.15],
                       np.float32)
        f.set_particles(pos, np.tile(np.float32([0.5, 0.0, 0.0]), (len(pos), 1)))
        f.set_outflow(("mesh", (0.6, 0.3, 0.5), (0.1, 0.1, 0.1), (1, 0, 0, 0), field))
        f.step()
        assert f.outflow_removed == 2
        left, _ = f.particles()
        assert np.count_nonzero(left[:, 1] == np.float32(0.39)) == 8


def effect(fluid_params=STILL, **inputs):
    return get("fluid")({"fluid": fluid_params}, inputs)


def test_a_tap_into_a_drain_pours_for_good():
    """33 particles a frame into a fluid of at most 600 for 60 frames: about 2000 poured,
    never stopped at max_particles (no note), and at every frame the count is the count
    before plus what was poured less what was drained."""
    e = effect(dict(POOL, max_particles=600), inflow={1: TAP},
               inflow_velocity=(1.0, 0.0, 0.0), outflow={1: FLOOR})
    try:
        poured = drained = 0
        for frame in range(1, 61):
            before = e.fluid.particle_count
            e.step(frame, None)
            added, capped = e.fluid.inflow_added
            assert not capped
            assert e.fluid.particle_count == before + added - e.fluid.outflow_removed
            poured += added
            drained += e.fluid.outflow_removed
        assert poured > 1500 and drained > poured - 600, (poured, drained)
        assert e.notes() == []
    finally:
        e.close()
    # the same tap without the drain stops at 600, and says so
    e = effect(dict(POOL, max_particles=600), inflow={1: TAP}, inflow_velocity=(1.0, 0.0, 0.0))
    try:
        for frame in range(1, 25):
            e.step(frame, None)
        assert e.fluid.particle_count == 600
        assert e.notes() and "stopped pouring" in e.notes()[0]
    finally:
        e.close()


def test_a_drain_opened_at_frame_3_and_closed_at_6_drains_in_frames_3_to_5_only():
    """A pool from x = 0.1 to 0.9, three quarters of it in the drain (x 0.3..0.9): that part
    goes in frame 3's first substep, more of the rest as it flows in, nothing before 3 or
    after 5."""
    e = effect(POOL, fill=((0.1, 0.3, 0.0), (0.9, 0.7, 0.1)), outflow={3: FLOOR, 6: None})
    try:
        drained = {}
        for frame in range(1, 9):
            before = e.fluid.particle_count
            if frame == 3:
                pos, _ = e.fluid.particles()
                inside = np.count_nonzero((pos[:, 0] > 0.3) & (pos[:, 0] < 0.9) &
                                          (pos[:, 2] < 0.15))
            e.step(frame, None)
            drained[frame] = before - e.fluid.particle_count
            assert drained[frame] == e.fluid.outflow_removed
        assert {f: n for f, n in drained.items() if f not in (3, 4, 5)} == \
            {1: 0, 2: 0, 6: 0, 7: 0, 8: 0}
        assert inside > 1000 and abs(drained[3] - inside) <= 0.05 * inside, (inside, drained)
        assert drained[4] + drained[5] > 0, drained
    finally:
        e.close()


def test_outflow_inputs_are_checked_by_name():
    fill = ((0.6, 0.6, 0.0), (0.8, 0.8, 0.1))
    for outflow, want in (
            (DRAIN, r"^outflow: tuple: must be a dict \{frame: shape or None\}"),
            ([DRAIN], r"^outflow\[0\]: tuple: must be a dict \{frame: shape or None\}"),
            ({3: ("sphere", (0.5, 0.5), 0.1)}, r"^outflow\[3\]\.centre: must have 3 numbers"),
            ({1: None, 4: ("mesh", (0.5, 0.5, 0.5), (0.1, 0.1, 0.1), (1, 0, 0, 0),
                           np.full((2, 2, 2), np.inf, np.float32))},
             r"^outflow\[4\]\.field\[0, 0, 0\] = inf: must be a finite distance")):
        with pytest.raises(errors.InvalidArgument, match=want):
            effect(fill=fill, outflow=outflow)
    for source in ("PARTICLES", "VELOCITY_GRID"):
        with pytest.raises(errors.InvalidArgument, match=r"^outflow: only the simulation "
                                                         r"\(source SIMULATE\) drains an "
                                                         r"outflow"):
            effect(dict(STILL, source=source), outflow={1: DRAIN})


def test_what_a_resume_compares_names_the_drain():
    """The frame's inputs carry the drain's shape at that frame (None's digest before and
    after); none without an outflow."""
    moved = ("box", (0.62, 0.5, 0.5), DRAIN[2])
    fill = ((0.3, 0.3, 0.0), (0.9, 0.7, 0.1))
    a = effect(fill=fill, outflow={3: DRAIN, 6: None})
    b = effect(fill=fill, outflow={3: moved, 6: None})
    plain = effect(fill=fill)
    try:
        outs = {f: a.frame_inputs(f)["outflow"] for f in range(1, 9)}
        assert outs[1] == outs[2] == outs[6] == outs[8] != outs[3] == outs[4] == outs[5]
        for f in range(1, 9):
            assert (b.frame_inputs(f)["outflow"] == outs[f]) == (f not in (3, 4, 5))
        assert "outflow" not in plain.frame_inputs(3)
    finally:
        for e in (a, b, plain):
            e.close()


def pour(folder, end, resume=False, drain=FLOOR):
    """Bakes frames 1..end of a jittered tap pouring from frame 1 into a drain opened at
    frame 3; returns the runner and the particles' bytes at the end."""
    return baked({"fill": ((0.3, 0.3, 0.0), (0.7, 0.7, 0.06)), "jitter": 0.2,
                  "inflow": {1: TAP}, "inflow_velocity": (1.0, 0.0, -0.5),
                  "outflow": {3: drain}}, folder, end, resume, POOL)


def test_a_bake_cut_while_draining_and_resumed_gives_the_same_bytes(tmp_path):
    assert_resumed_alike(tmp_path, pour)  # (cut with the drain open)
    # another drain is another bake: refused at the first frame it drains
    pour(tmp_path / "c", 4)
    with pytest.raises(errors.StateError, match=r"^cannot resume the bake in .*: outflow at "
                                                r"frame 3: changed since the bake"):
        pour(tmp_path / "c", 8, resume=True, drain=("box", (0.62, 0.5, 0.0), FLOOR[2]))
