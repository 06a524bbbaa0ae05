"""VDB grids through pyopenvdb: standard names, vector types, atomic writes."""
import os

import numpy as np
import pytest

from hydrobake.core import errors, vdb


def test_grids_round_trip_with_vector_type(tmp_path):
    dens = np.zeros((8, 9, 10), np.float32)
    dens[2:5, 3:6, 4:7] = 0.5
    vel = np.zeros((8, 9, 10, 3), np.float32)
    vel[..., 0] = 1.5
    p = tmp_path / "v.vdb"
    vdb.write(str(p), [dict(name="density", array=dens, voxel_size=0.1),
                       dict(name="velocity", array=vel, voxel_size=0.1,
                            vector_type="CONTRAVARIANT_RELATIVE")])
    grids = vdb.read(str(p))
    assert set(grids) == {"density", "velocity"}
    assert grids["density"].activeVoxelCount() == 27
    assert grids["velocity"].vectorType == "contravariant relative"
    back = np.zeros_like(dens)
    grids["density"].copyToArray(back)
    np.testing.assert_array_equal(back, dens)
    assert grids["density"].transform.voxelSize() == pytest.approx((0.1, 0.1, 0.1))
    assert os.listdir(tmp_path) == ["v.vdb"]


def test_bad_grids_are_refused(tmp_path):
    with pytest.raises(errors.InvalidArgument, match="shape"):
        vdb.make_grid("density", np.zeros((4, 4)))
    with pytest.raises(errors.InvalidArgument, match="vector_type"):
        vdb.make_grid("v", np.zeros((2, 2, 2, 3)), vector_type="SIDEWAYS")
    with pytest.raises(errors.InvalidArgument, match="NaN"):
        vdb.make_grid("density", np.full((2, 2, 2), np.nan))
    with pytest.raises(errors.InvalidArgument, match="duplicate"):
        vdb.write(str(tmp_path / "d.vdb"), [dict(name="a", array=np.zeros((2, 2, 2))),
                                           dict(name="a", array=np.zeros((2, 2, 2)))])
    assert os.listdir(tmp_path) == []
