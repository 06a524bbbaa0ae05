"""Regression of bakes against a golden bake: metrics, tolerances, reports, exit codes."""
import json
import math
import os
import shutil

import numpy as np
import pytest

from hydrobake.core import exr, regress, vdb
from hydrobake.core.bake import BakeCache, BakeRunner
from fixture_effect import WaveEffect


@pytest.fixture
def golden(tmp_path):
    g = tmp_path / "golden" / "shot" / "Plane_testwave"
    BakeRunner(WaveEffect(), g, 1, 3).run()
    return tmp_path / "golden"


def test_metrics_are_right():
    a = np.zeros((4, 4), np.float32)
    b = a.copy()
    b[0, 0] = 2.0
    m = regress.image_metrics(b, a + 0)
    assert m["max_abs"] == 2.0 and m["mean_abs"] == pytest.approx(2 / 16)
    g = np.full((4, 4), 4.0, np.float32)
    m = regress.image_metrics(g + 0.04, g)  # mse 0.0016, peak 4: PSNR = 10 log10(16/0.0016)
    assert m["psnr"] == pytest.approx(40.0, abs=1e-3)
    assert regress.image_metrics(g, g)["psnr"] == math.inf


def test_identical_bake_passes(golden, tmp_path, capsys):
    new = tmp_path / "new" / "shot" / "Plane_testwave"
    BakeRunner(WaveEffect(), new, 1, 3).run()
    assert regress.main([str(tmp_path / "new"), str(golden), "--report",
                         str(tmp_path / "rep")]) == 0
    out = capsys.readouterr().out
    assert "3 files match, 0 regressions" in out
    rep = json.loads((tmp_path / "rep" / "report.json").read_text())
    assert rep["passed"] and all(c["max_abs"] == 0 for e in rep["files"]
                                 for c in e["channels"].values())
    assert "PASSED" in (tmp_path / "rep" / "report.html").read_text()


def _raised_copy(golden, tmp_path, frame, delta):
    """A copy of the golden set whose wave frame ``frame`` is ``delta`` higher."""
    new = tmp_path / "new"
    shutil.copytree(golden, new)
    p = new / "shot" / "Plane_testwave" / f"wave_{frame:04d}.exr"
    ch = exr.read(p)
    ch["height"] = ch["height"] + delta
    exr.write(p, ch, half=("R", "G", "B"))
    return new


def test_a_changed_bake_fails_with_the_channel_and_a_picture(golden, tmp_path, capsys):
    new = _raised_copy(golden, tmp_path, 2, 0.01)
    os.remove(new / "shot" / "Plane_testwave" / "wave_0003.exr")
    rep_dir = tmp_path / "rep"
    assert regress.main([str(new), str(golden), "--report", str(rep_dir)]) == 1
    out = capsys.readouterr().out
    assert "FAIL shot/Plane_testwave/wave_0002.exr" in out and "height: max |diff|" in out
    assert "wave_0003.exr" in out and "missing in the new bake" in out
    page = (rep_dir / "report.html").read_text()
    assert "FAILED" in page and "_golden.png" in page and "_diff.png" in page
    assert any(n.endswith("_diff.png") for n in os.listdir(rep_dir))


def test_tolerances_per_effect_and_stream(golden, tmp_path):
    new = _raised_copy(golden, tmp_path, 1, 1e-3)
    loose = {"testwave": {"wave": {"max_abs": 1e-2}}}
    assert regress.compare(new, golden, loose)["passed"]
    strict = {"testwave": {"wave": {"max_abs": 1e-4}}}
    assert not regress.compare(new, golden, strict)["passed"]


@pytest.mark.parametrize("table, want", [
    # A misspelt key checked nothing: every regression passed.
    ({"*": {"*": {"maxabs": 1e-4}}}, "tolerances: */*: 'maxabs' is not a tolerance "
     "(tolerances: max_abs, mean_abs, min_psnr, max_voxel_delta)"),
    # NaN passes every comparison.
    ({"testwave": {"wave": {"max_abs": float("nan")}}}, "testwave/wave: max_abs = NaN: must be "
     "a finite number >= 0"),
    ({"testwave": {"wave": {"min_psnr": -1}}}, "min_psnr = -1: must be a finite number >= 0"),
    ({"testwave": {"wave": {"max_abs": True}}}, "max_abs = true: must be a finite number"),
    ({"testwave": {"wave": {"max_abs": "0.1"}}}, 'max_abs = "0.1": must be a finite number'),
    ({"testwave": {"wave": 0.1}}, "testwave/wave: must be an object of tolerances"),
    ({"testwave": 0.1}, "testwave: must be an object of streams"),
    ([1], "tolerances: must be a JSON object"),
])
def test_tolerances_that_would_check_less_are_refused(golden, table, want):
    with pytest.raises(ValueError) as exc:
        regress.compare(golden, golden, table)
    assert want in str(exc.value)


def test_a_stream_without_tolerances_is_a_regression_not_a_pass(golden, tmp_path):
    """A table naming other effects only left the bake's streams unchecked: it passed
    whatever the files held."""
    new = _raised_copy(golden, tmp_path, 1, 1.0)
    rep = regress.compare(new, golden, {"snow": {"*": {"max_abs": 1.0}}})
    assert not rep["passed"]
    assert "no tolerance for testwave/wave: name it, testwave/*, or */* in the tolerances" in \
        rep["files"][0]["problems"], rep["files"][0]["problems"]
    assert regress.compare(new, golden, {"*": {"*": {"max_abs": 2.0}}})["passed"]


def test_a_tolerances_file_is_checked_and_named(golden, tmp_path, capsys):
    bad = tmp_path / "tol.json"
    bad.write_text('{"*": {"*": {"max_abs": 1e-4,}}}')
    with pytest.raises(SystemExit) as exc:
        regress.main([str(golden), str(golden), "--tolerances", str(bad)])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert f"--tolerances {bad}: not valid JSON" in err and "Traceback" not in err, err
    bad.write_text(json.dumps({"*": {"*": {"psnr": 40}}}))
    with pytest.raises(ValueError, match=f"--tolerances {bad}: \\*/\\*: 'psnr' is not a "):
        regress.load_tolerances(str(bad))
    with pytest.raises(ValueError, match="--tolerances /nonexistent.json: No such file"):
        regress.load_tolerances("/nonexistent.json")
    assert regress.load_tolerances(os.path.join(os.path.dirname(__file__), "..", "golden",
                                                "tolerances.json")) == regress.DEFAULT_TOLERANCES


def test_a_damaged_file_is_a_regression_and_the_rest_is_compared(golden, tmp_path, capsys):
    """A truncated EXR in the new bake (or garbage in the golden set) stopped the whole
    comparison with a traceback, and no report was written."""
    new = tmp_path / "new"
    shutil.copytree(golden, new)
    with open(new / "shot" / "Plane_testwave" / "wave_0001.exr", "r+b") as f:
        f.truncate(100)
    (golden / "shot" / "Plane_testwave" / "wave_0002.exr").write_bytes(b"garbage")
    rep_dir = tmp_path / "rep"
    assert regress.main([str(new), str(golden), "--report", str(rep_dir)]) == 1
    out = capsys.readouterr().out
    assert "FAIL shot/Plane_testwave/wave_0001.exr" in out and "unreadable:" in out, out
    assert "FAIL shot/Plane_testwave/wave_0002.exr" in out, out
    assert "ok   shot/Plane_testwave/wave_0003.exr" in out, out
    rep = json.loads((rep_dir / "report.json").read_text())
    assert [bool(e["problems"]) for e in rep["files"]] == [True, True, False]
    assert "wave_0001.exr" in rep["files"][0]["problems"][0]  # names the damaged file


def test_vdb_grids_compare_voxels_and_values(tmp_path):
    for name, shift in (("golden", 0.0), ("new", 0.5)):
        folder = tmp_path / name / "b"
        folder.mkdir(parents=True)
        d = np.zeros((8, 8, 8), np.float32)
        d[2:5, 2:5, 2:5] = 1.0 + shift
        vdb.write(str(folder / "fluid_0001.vdb"), [dict(name="density", array=d)])
        c = BakeCache(folder)
        m = c.start({"effect": "fluid", "streams": ["fluid"]})
        c.add_frame(m, 1, ["fluid_0001.vdb"])
    rep = regress.compare(tmp_path / "new", tmp_path / "golden")
    ch = rep["files"][0]["channels"]["density"]
    assert ch["voxels"] == 27 and ch["voxel_delta"] == 0 and ch["max_abs"] == 0.5
    assert not rep["passed"]


def test_empty_vdb_grids_compare_cleanly(tmp_path):
    for name in ("golden", "new"):
        folder = tmp_path / name / "b"
        folder.mkdir(parents=True)
        vdb.write(str(folder / "fluid_0001.vdb"), [dict(name="density",
                                                        array=np.zeros((4, 4, 4), np.float32))])
        c = BakeCache(folder)
        m = c.start({"effect": "fluid", "streams": ["fluid"]})
        c.add_frame(m, 1, ["fluid_0001.vdb"])
    rep = regress.compare(tmp_path / "new", tmp_path / "golden")
    assert rep["passed"] and rep["files"][0]["channels"]["density"]["voxels"] == 0


def test_files_are_matched_without_their_bakes_tags(golden, tmp_path, capsys):
    # The golden bake has no tag (from before tags); the new one names its folder. A new
    # bake's frame changed must still be found and fail.
    new = tmp_path / "new" / "shot" / "Plane_testwave"
    BakeRunner(WaveEffect(), new, 1, 3, header={"file_tag": "shot_Plane_testwave_"}).run()
    assert regress.main([str(tmp_path / "new"), str(golden), "--report",
                         str(tmp_path / "rep")]) == 0
    assert "3 files match, 0 regressions" in capsys.readouterr().out
    p = new / "shot_Plane_testwave_wave_0002.exr"
    ch = exr.read(p)
    ch["height"] = ch["height"] + 0.01
    exr.write(p, ch, half=("R", "G", "B"))
    assert regress.main([str(tmp_path / "new"), str(golden), "--report",
                         str(tmp_path / "rep")]) == 1
    assert "FAIL shot/Plane_testwave/wave_0002.exr" in capsys.readouterr().out
    rep = json.loads((tmp_path / "rep" / "report.json").read_text())
    assert any(n.endswith("_diff.png") for n in os.listdir(tmp_path / "rep"))
    assert [e["paths"]["new"] for e in rep["files"] if e["problems"]] == [str(p)]
