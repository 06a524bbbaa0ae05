"""The shipped golden set of examples.blend, checked by the regress command in Blender."""
import json
import os
import shutil

from hydrobake_paths import ROOT

GOLDEN = os.path.join(ROOT, "tests", "golden")


def _regress(blender, tmp_path, overrides, name, *select):
    blend = tmp_path / "examples.blend"  # the golden set's folder is named after the file
    if not blend.exists():
        shutil.copy(os.path.join(ROOT, "examples.blend"), blend)
    report = tmp_path / f"report_{name}"
    return blender.run("cli.py", "regress", "--golden", os.path.join(GOLDEN, "examples"),
                       "--frames", "1-2", "--overrides", overrides, "--tolerances",
                       os.path.join(GOLDEN, "tolerances.json"), "--report", report,
                       "--output", tmp_path / f"bake_{name}", *select, blend=str(blend),
                       check=False), \
        report


def test_examples_match_the_golden_set(blender, tmp_path):
    r, report = _regress(blender, tmp_path, os.path.join(GOLDEN, "overrides.json"), "same")
    assert r.returncode == 0, r.stdout[-3000:] + r.stderr[-2000:]
    assert "0 regressions" in r.stdout
    rep = json.loads((report / "report.json").read_text())
    # Per frame: caustics 4 files, snow 3 objects x 2, rain 3, fluid 2.
    assert rep["passed"] and len(rep["files"]) == 2 * (4 + 3 * 2 + 3 + 2)


def test_a_changed_setting_is_caught(blender, tmp_path):
    table = json.load(open(os.path.join(GOLDEN, "overrides.json")))
    table["Water/caustics"]["light"] = {"absorption": [0.9, 0.2, 0.05]}
    changed = tmp_path / "changed.json"
    changed.write_text(json.dumps(table))
    r, report = _regress(blender, tmp_path, changed, "changed")
    assert r.returncode == 1 and "regressions against" in r.stderr
    assert "FAIL Water_caustics/caustics_0001.exr" in r.stdout
    assert "FAIL Water_caustics/water_0001.exr" not in r.stdout  # absorption is light only
    assert "Water_caustics" in (report / "report.html").read_text()


def test_a_selection_is_compared_with_its_part_of_the_golden_set(blender, tmp_path):
    r, report = _regress(blender, tmp_path, os.path.join(GOLDEN, "overrides.json"), "part",
                         "--objects", "Water", "--effects", "caustics")
    assert r.returncode == 0, r.stdout[-3000:] + r.stderr[-2000:]
    rep = json.loads((report / "report.json").read_text())
    assert rep["passed"] and {f["bake"] for f in rep["files"]} == {"Water_caustics"}
    assert len(rep["files"]) == 2 * 4 and not rep["problems"], rep["problems"]


def test_a_bad_tolerances_file_is_refused_before_baking(blender, tmp_path):
    blend = tmp_path / "examples.blend"
    shutil.copy(os.path.join(ROOT, "examples.blend"), blend)
    bad = tmp_path / "tol.json"
    bad.write_text(json.dumps({"*": {"*": {"max_abs": 1e-4, "mean_ab": 1e-5}}}))
    r = blender.run("cli.py", "regress", "--golden", os.path.join(GOLDEN, "examples"),
                    "--tolerances", bad, "--output", tmp_path / "bake", blend=str(blend),
                    check=False)
    assert r.returncode == 1 and "Traceback" not in r.stderr, r.stderr[-2000:]
    assert f"hydrobake: error: --tolerances {bad}: */*: 'mean_ab' is not a tolerance" in \
        r.stderr, r.stderr[-2000:]
    assert not (tmp_path / "bake").exists()  # refused before the bake, not after it
