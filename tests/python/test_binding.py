"""The ctypes binding: loading, declared signatures, struct mirrors, errors as exceptions."""
import ctypes
import os
import subprocess
import sys

import numpy as np
import pytest

from hydrobake import core
from hydrobake.core import _lib, errors, image


def test_loads_from_plain_python_without_bpy():
    assert "bpy" not in sys.modules
    assert core.version == "0.1.0"
    assert os.path.isfile(core.library_path())


def test_environment_override_is_used(tmp_path):
    # A wrong override must fail clearly at import, naming the variable.
    code = "import hydrobake.core"
    env = dict(os.environ, HYDROBAKE_LIB=str(tmp_path / "nope.so"),
               PYTHONPATH=os.path.dirname(os.path.dirname(os.path.dirname(core.__file__))))
    r = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True)
    assert r.returncode != 0
    assert "HYDROBAKE_LIB" in r.stderr and "nope.so" in r.stderr
    env["HYDROBAKE_LIB"] = core.library_path()
    r = subprocess.run([sys.executable, "-c", code + "; print(hydrobake.core.library_path())"],
                       env=env, capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert r.stdout.strip() == core.library_path()


def test_struct_mirrors_match_the_library():
    for cls, name in ((_lib.Image, "hbk_image_t"), (_lib.Progress, "hbk_progress_t"),
                      (_lib.ExrChannel, "hbk_exr_channel_t"), (_lib.ParamInfo, "hbk_param_info_t")):
        _lib.check_mirror(cls, name)
        assert ctypes.sizeof(cls) == _lib.layout(name)


def test_a_drifted_mirror_is_caught():
    class Wrong(ctypes.Structure):
        _fields_ = [("data", ctypes.c_void_p), ("width", ctypes.c_int32),
                    ("height", ctypes.c_int32), ("row_stride", ctypes.c_size_t)]  # lost a field
    with pytest.raises(errors.VersionMismatch, match="hbk_image_t"):
        _lib.check_mirror(Wrong, "hbk_image_t")


def test_result_strings():
    assert _lib.lib.hbk_result_string(0) == b"success"
    assert _lib.lib.hbk_result_string(5) == b"cancelled"


def test_normal_map_of_a_plane():
    h = np.fromfunction(lambda y, x: 0.5 * x * 0.1 - 0.25 * y * 0.1, (16, 16), dtype=np.float32)
    n = image.normal_map(h.astype(np.float32), texel_size=(0.1, 0.1))
    want = np.array([-0.5, 0.25, 1.0]) / np.sqrt(0.5**2 + 0.25**2 + 1)
    np.testing.assert_allclose(n[5, 5], want, atol=1e-6)
    enc = image.normal_map(h.astype(np.float32), texel_size=(0.1, 0.1), encode=True)
    np.testing.assert_allclose(enc[5, 5], want * 0.5 + 0.5, atol=1e-6)


def test_bad_arrays_fail_before_the_call():
    with pytest.raises(errors.InvalidArgument, match="dtype must be float32"):
        image.normal_map(np.zeros((4, 4), np.float64))
    with pytest.raises(errors.InvalidArgument, match="C-contiguous"):
        image.normal_map(np.zeros((4, 8), np.float32)[:, ::2])
    with pytest.raises(errors.InvalidArgument, match="1 channel"):
        image.normal_map(np.zeros((4, 4, 2), np.float32))


def test_library_errors_become_exceptions_with_the_parameter():
    h = np.zeros((4, 4), np.float32)
    with pytest.raises(errors.InvalidArgument, match=r"^strength = -2: must be in \[0, 1000\]"):
        image.normal_map(h, strength=-2)
    with pytest.raises(errors.InvalidArgument, match=r"texel_size = \(0, 1\)"):
        image.normal_map(h, texel_size=(0, 1))
    with pytest.raises(ValueError):  # InvalidArgument is a ValueError for plain callers
        image.normal_map(h, strength=float("nan"))


def test_grid_to_xyz_is_the_transpose_and_refuses_bad_grids():
    from hydrobake.core import arrays
    rng = np.random.default_rng(5)
    for shape in ((33, 7, 18), (5, 4, 3, 3), (17, 2, 40, 5)):
        a = rng.random(shape, np.float32)
        want = np.ascontiguousarray(np.swapaxes(a, 0, 2))
        for threads in (1, 2):
            got = arrays.grid_to_xyz(a, threads)
            assert got.flags.c_contiguous and got.shape == want.shape
            np.testing.assert_array_equal(got, want)
    with pytest.raises(errors.InvalidArgument):
        arrays.grid_to_xyz(np.zeros((2, 2, 2), np.float64))
    with pytest.raises(errors.InvalidArgument, match="comps = 17"):
        arrays.grid_to_xyz(np.zeros((2, 2, 2, 17), np.float32))
