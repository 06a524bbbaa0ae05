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


DATA = os.path.join(os.path.dirname(os.path.abspath(__file__)), "data")


@pytest.mark.parametrize("compression", ["ZIP", "ZIPS"])
def test_a_chunk_zlib_cannot_shorten_reads_back_exactly(tmp_path, compression):
    """Sixteen rows of a snow depth map whose ZIP chunk deflates to exactly its raw length:
    OpenEXRCore 3.1.5 stored the zlib stream, which every reader takes for raw pixels, and
    read back noise and NaN (openexr#2306). The writer stores such a chunk raw."""
    depth = np.load(os.path.join(DATA, "exr_zip_chunk_as_long_as_raw.npy"))
    exr.write(tmp_path / "d.exr", {"Y": depth}, compression=compression)
    np.testing.assert_array_equal(exr.read(tmp_path / "d.exr")["Y"], depth)


def test_many_partly_compressible_images_read_back_exactly(tmp_path):
    """Rows of smooth values with random low bits, as the bakes' maps are, near the size
    where deflate stops paying: every chunk reads back bit for bit, in float and half."""
    rng = np.random.default_rng(7)
    for k in range(120):
        h, w = int(rng.integers(1, 40)), int(rng.integers(1, 70))
        smooth = np.cumsum(rng.normal(0, 1e-4, (h, w)), axis=1).astype(np.float32)
        noise = rng.random((h, w)) < rng.random()  # from all smooth to all noise
        img = np.where(noise, rng.random((h, w)), smooth).astype(np.float32)
        half = bool(k % 2)
        if half:
            img = img.astype(np.float16).astype(np.float32)
        p = tmp_path / f"r{k}.exr"
        exr.write(p, {"Y": img}, half=True if half else (),
                  compression=("ZIP", "ZIPS")[k % 3 == 0])
        np.testing.assert_array_equal(exr.read(p)["Y"], img, err_msg=f"image {k}")
