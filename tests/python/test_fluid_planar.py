"""A planar inflow's sheet through the binding: the field the addon makes of an open mesh
(its unsigned distance less t, t = 0.55 spacings: mesh_fields.sheet_shape) holds one lattice
layer or two wherever the inflow's lattice falls across it, never none, so a Plane pours its
whole area's columns at any height; half a spacing less would leave it dry at some."""
import numpy as np
import pytest

from hydrobake.core import fluid
from test_fluid_inflow import STILL

S = 0.02  # STILL's particle_spacing


def sheet(offset, t, side=0.17):
    """A horizontal sheet at z = 0.5 (a field of |z - 0.5| - t over a box whose centre is
    ``offset`` above it: where the inflow's lattice falls across the sheet)."""
    nz = 21
    half = (side / 2, side / 2, 0.05)
    z = np.linspace(0.5 + offset - half[2], 0.5 + offset + half[2], nz)
    field = np.broadcast_to((np.abs(z - 0.5) - t)[:, None, None], (nz, 17, 17))
    return ("mesh", (0.5, 0.5, 0.5 + offset), half, (1.0, 0.0, 0.0, 0.0),
            np.ascontiguousarray(field, np.float32))


def layers(offset, t):
    """(columns, points) of the sheet poured straight down at 1 m/s."""
    with fluid.Fluid(STILL) as f:
        assert f.params.particle_spacing == pytest.approx(S)
        f.set_inflow(sheet(offset, t), (0.0, 0.0, -1.0))
        return f.inflow_rate * S, f.inflow_points


@pytest.mark.parametrize("offset", np.arange(0.0, S, S / 8))
def test_the_sheet_pours_its_whole_area_wherever_the_lattice_falls(offset):
    columns, points = layers(offset, 0.55 * S)
    # (8 x 8 lattice columns across the 17 cm square, a spacing apart)
    assert round(columns) == 64 and points in (64, 128), (columns, points)


def test_a_thinner_sheet_leaves_the_plane_dry_where_the_lattice_straddles_it():
    got = [layers(offset, 0.45 * S)[0] for offset in np.arange(0.0, S, S / 8)]
    assert min(got) == 0 and max(got) > 0, got
