"""Several drains through the binding and the core effect: added drains take exactly what
each takes alone; a list of schedules opens each at its own frames; refusals name the
drain; the forecast waits for the first to open; a bake cut while two drain resumes to the
same bytes."""
import numpy as np
import pytest

from hydrobake.core import errors, fluid
from hydrobake.core.effects import get
from test_fluid_inflow import assert_resumed_alike, baked
from test_fluid_outflow import POOL, STILL, TAP, coasting

LEFT = ("box", (0.3, 0.5, 0.5), (0.05, 0.5, 0.5))  # x in (0.25, 0.35)
RIGHT = ("sphere", (0.7, 0.3, 0.5), 0.06)  # around x 0.65 of the row at y 0.3


def test_added_drains_take_what_each_takes_alone():
    kept = {}
    for name, drains in (("none", []), ("left", [LEFT]), ("right", [RIGHT]),
                         ("both", [LEFT, RIGHT])):
        with fluid.Fluid(STILL) as f:
            x0 = coasting(f)
            for k, d in enumerate(drains):
                (f.add_outflow if k else f.set_outflow)(d)
            f.step()
            pos, _ = f.particles()
            kept[name] = {(round(float(x), 3), round(float(y), 3)) for x, y in pos[:, :2]}
            assert f.outflow_removed == len(x0) - len(pos)
    gone = {k: kept["none"] - kept[k] for k in ("left", "right", "both")}
    # each takes some, the two different ones, and both together exactly what each takes
    assert gone["left"] and gone["right"] and not gone["left"] & gone["right"], gone
    assert gone["both"] == gone["left"] | gone["right"], gone
    with fluid.Fluid(STILL) as f:
        for bad, want in ((None, r"^shape"), (("sphere", (0.5, 0.5), 0.1),
                                              r"^shape\.centre: must have 3 numbers")):
            with pytest.raises(errors.InvalidArgument, match=want):
                f.add_outflow(bad)


def effect(fluid_params=STILL, **inputs):
    return get("fluid")({"fluid": fluid_params}, inputs)


def test_each_drain_opens_at_its_own_frames():
    """A pool over the whole floor; the left drain from frame 2, the right one from frame 4:
    frame 2 and 3 drain only the left, frame 4 the right's inside too."""
    fill = ((0.1, 0.1, 0.0), (0.9, 0.9, 0.08))
    left = ("box", (0.2, 0.5, 0.05), (0.1, 0.4, 0.05))
    right = ("box", (0.8, 0.5, 0.05), (0.1, 0.4, 0.05))
    e = effect(dict(POOL, max_particles=8000), fill=fill,
               outflow=[{2: left}, {1: None, 4: right}])
    try:
        drained = {}
        for frame in range(1, 6):
            before = e.fluid.particle_count
            pos, _ = e.fluid.particles()
            at_right = np.count_nonzero((pos[:, 0] > 0.7) & (pos[:, 2] < 0.1))
            e.step(frame, None)
            drained[frame] = before - e.fluid.particle_count
            if frame == 4:
                assert drained[4] > 0.8 * at_right, (drained, at_right)
        assert drained[1] == 0 and drained[2] > 0 and drained[3] < drained[2] and \
            drained[4] > drained[3], drained
        assert e.frame_inputs(3)["outflow"] != e.frame_inputs(4)["outflow"]
    finally:
        e.close()
    for outflow, want in (([{1: LEFT}, {3: ("sphere", (0.5, 0.5), 0.1)}],
                           r"^outflow\[1\]\[3\]\.centre: must have 3 numbers"),
                          ([{1: LEFT}, [RIGHT]], r"^outflow\[1\]: list: must be a dict")):
        with pytest.raises(errors.InvalidArgument, match=want):
            effect(outflow=outflow)


def test_the_forecast_stops_where_the_first_drain_opens():
    """A tap filling a small fluid, a drain opening at frame 30 and another at 5: the
    forecast says nothing (the first drain opens before the fluid fills); with the frame-5
    drain alone at frame 30 it names its frame."""
    params = dict(POOL, max_particles=1200)
    far = ("box", (0.9, 0.9, 0.9), (0.05, 0.05, 0.05))
    kw = dict(fill=((0.3, 0.3, 0.0), (0.7, 0.7, 0.04)), inflow={1: TAP},
              inflow_velocity=(1.0, 0.0, 0.0))
    e = effect(params, outflow=[{30: far}, {5: far}], **kw)
    try:
        assert e.forecast(1, 60) == []
    finally:
        e.close()
    e = effect(params, outflow=[{30: far}, {1: None}], **kw)
    try:
        (text,) = e.forecast(1, 60)
        assert "until the outflow opens at frame 30" in text, text
    finally:
        e.close()


def test_a_bake_cut_while_two_drains_drain_resumes_to_the_same_bytes(tmp_path):
    inputs = {"fill": ((0.3, 0.3, 0.0), (0.7, 0.7, 0.06)), "jitter": 0.2,
              "inflow": {1: TAP}, "inflow_velocity": (1.0, 0.0, -0.5),
              "outflow": [{3: ("box", (0.6, 0.5, 0.0), (0.1, 0.5, 0.15))},
                          {2: ("box", (0.35, 0.35, 0.0), (0.05, 0.05, 0.15)), 6: None}]}
    assert_resumed_alike(tmp_path, lambda folder, end, resume=False:
                         baked(inputs, folder, end, resume))
