"""EXR through the binding: round trips, orientation, atomic writes, errors."""
import os

import numpy as np
import pytest

from hydrobake.core import errors, exr


def test_roundtrip_float_exact_and_half_close(tmp_path):
    rng = np.random.default_rng(1)
    f = rng.normal(size=(17, 23)).astype(np.float32)
    h = rng.uniform(-4, 4, size=(17, 23)).astype(np.float32)
    p = tmp_path / "a.exr"
    exr.write(p, {"height": f, "R": h}, half=("R",))
    with exr.Reader(p) as r:
        assert r.size == (23, 17)
        assert r.channels == {"R": True, "height": False}
        np.testing.assert_array_equal(r.read("height"), f)
        np.testing.assert_allclose(r.read("R"), h, rtol=2**-10, atol=1e-7)


def test_rows_keep_their_orientation(tmp_path):
    img = np.zeros((8, 4), np.float32)
    img[0, :] = 1.0  # bottom row
    exr.write(tmp_path / "o.exr", {"Y": img})
    back = exr.read(tmp_path / "o.exr")["Y"]
    assert back[0].tolist() == [1, 1, 1, 1] and back[-1].tolist() == [0, 0, 0, 0]


def test_failed_write_keeps_the_old_file_and_leaves_nothing(tmp_path):
    p = tmp_path / "keep.exr"
    exr.write(p, {"Y": np.ones((4, 4), np.float32)})
    before = p.read_bytes()
    with pytest.raises(errors.InvalidArgument):
        exr.write(p, {"Y": np.ones((4, 4), np.float32), "": np.ones((4, 4), np.float32)})
    assert p.read_bytes() == before
    assert sorted(os.listdir(tmp_path)) == ["keep.exr"]


def test_errors_name_the_problem(tmp_path):
    with pytest.raises(errors.InvalidArgument, match="shape"):
        exr.write(tmp_path / "x.exr", {"A": np.zeros((2, 2)), "B": np.zeros((3, 2))})
    with pytest.raises(errors.InvalidArgument, match="compression"):
        exr.write(tmp_path / "x.exr", {"A": np.zeros((2, 2))}, compression="JPEG")
    with pytest.raises(errors.FileIOError):
        exr.write(tmp_path / "no" / "such" / "dir.exr", {"A": np.zeros((2, 2))})
    with pytest.raises(errors.FileIOError):
        exr.Reader(tmp_path / "missing.exr")
    exr.write(tmp_path / "ok.exr", {"A": np.zeros((2, 2))})
    with exr.Reader(tmp_path / "ok.exr") as r, pytest.raises(errors.InvalidArgument, match="B"):
        r.read("B")
    (tmp_path / "junk.exr").write_bytes(b"not an exr at all" * 10)
    with pytest.raises((errors.FormatError, errors.FileIOError)):
        exr.Reader(tmp_path / "junk.exr")


def test_a_closed_reader_refuses_to_read(tmp_path):
    exr.write(tmp_path / "c.exr", {"A": np.zeros((2, 2))})
    r = exr.Reader(tmp_path / "c.exr")
    r.close()
    r.close()  # twice is harmless
    with pytest.raises(errors.StateError, match="closed"):
        r.read("A")
