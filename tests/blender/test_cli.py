"""The batch command line in background mode: bake, progress lines, exit codes, kill safety."""
import json
import os
import shutil
import signal
import time

from hydrobake_paths import ROOT, frames_in


def _blend(blender, tmp_path):
    blend = str(tmp_path / "shot.blend")
    blender.run("make_fixture_blend.py", blend)
    return blend


def test_bake_all_enabled_with_output_override(blender, tmp_path):
    blend = _blend(blender, tmp_path)
    out = tmp_path / "farm_cache"
    r = blender.run("cli_fixture.py", "bake", "--frames", "2-5", "--output", out, blend=blend)
    lines = [l for l in r.stdout.splitlines() if l.startswith("hydrobake: Glass/testwave frame")]
    assert len(lines) == 4 and "elapsed" in lines[-1] and "remaining 0.0s" in lines[-1]
    for obj in ("Glass", "Rear"):
        folder = out / "shot" / f"{obj}_testwave"
        m = json.loads((folder / "manifest.json").read_text())
        assert m["complete"] and frames_in(folder) == [2, 3, 4, 5]
    # Only one object, by name; then free it.
    r = blender.run("cli_fixture.py", "free", "--objects", "Glass", "--effects", "testwave",
                    blend=blend)
    assert "Glass/testwave freed" in r.stdout


def test_errors_exit_non_zero_with_the_message_on_stderr(blender, tmp_path):
    blend = _blend(blender, tmp_path)
    r = blender.run("cli_fixture.py", "bake", "--effects", "nope", blend=blend, check=False)
    assert r.returncode == 1 and "--effects nope: not an effect" in r.stderr
    r = blender.run("cli_fixture.py", "bake", "--objects", "Missing", blend=blend, check=False)
    assert r.returncode == 1 and "--objects Missing" in r.stderr
    for frames in ("9-2", "5-"):
        r = blender.run("cli_fixture.py", "bake", "--frames", frames, blend=blend, check=False)
        assert r.returncode != 0 and f"--frames '{frames}'" in r.stderr, r.stderr
    # Overrides of the wrong shape or type are named, without a traceback.
    for table, want in (([1, 2], "must be a JSON object of objects"),
                        ({"*/testwave": {"frame_start": "soon"}},
                         "*/testwave: frame_start: ")):
        path = tmp_path / "overrides.json"
        path.write_text(json.dumps(table))
        r = blender.run("cli_fixture.py", "bake", "--overrides", path, blend=blend, check=False)
        assert r.returncode == 1 and want in r.stderr and "Traceback" not in r.stderr, r.stderr


def test_killed_bake_leaves_complete_frames_only(blender, tmp_path):
    blend = _blend(blender, tmp_path)
    out = tmp_path / "cache"
    blender.env["HBK_FIXTURE_DELAY"] = "0.3"
    try:
        p = blender.popen("cli_fixture.py", "bake", "--objects", "Glass", "--effects", "testwave",
                          "--frames", "1-100", "--output", out, blend=blend)
        folder = out / "shot" / "Glass_testwave"
        deadline = time.monotonic() + 60
        while len(frames_in(folder)) < 3 and time.monotonic() < deadline:
            time.sleep(0.05)
        p.send_signal(signal.SIGKILL)
        p.wait(10)
    finally:
        del blender.env["HBK_FIXTURE_DELAY"]
    m = json.loads((folder / "manifest.json").read_text())
    assert not m["complete"]
    done = sorted(int(f) for f in m["frames"])
    assert len(done) >= 3 and done == list(range(1, len(done) + 1))
    visible = sorted(n for n in os.listdir(folder) if not n.startswith("."))
    # Every visible frame file is a complete, recorded frame (at most one more that was
    # renamed just before the kill and not yet in the manifest, itself complete).
    assert visible[0] == "manifest.json"
    from hydrobake.core import exr
    for name in visible[1:]:
        assert exr.Reader(folder / name).size == (32, 32)


def test_overrides_are_for_the_run_not_saved_into_the_file(blender, tmp_path):
    blend = str(tmp_path / "examples.blend")
    shutil.copy(os.path.join(ROOT, "examples.blend"), blend)
    before = blender.run("show_setting.py", "Tank", "fluid", "fluid.resolution", blend=blend)
    overrides = tmp_path / "preview.json"
    overrides.write_text(json.dumps({"Tank/fluid": {"fluid": {"resolution": [32, 16, 16],
                                                              "substeps": 4}}}))
    blender.run("cli.py", "bake", "--objects", "Tank", "--effects", "fluid", "--frames", "1-2",
                "--overrides", overrides, "--output", tmp_path / "cache", blend=blend)
    after = blender.run("show_setting.py", "Tank", "fluid", "fluid.resolution", blend=blend)
    assert "(32, 16, 16)" not in before.stdout
    assert after.stdout.count("SETTING") == 1 and "BAKED True" in after.stdout
    assert before.stdout.split("SETTING")[1].split("BAKED")[0] == \
        after.stdout.split("SETTING")[1].split("BAKED")[0]  # the file's own resolution
    m = json.loads((tmp_path / "cache" / "examples" / "Tank_fluid" / "manifest.json").read_text())
    assert m["params"]["fluid"]["resolution"] == [32, 16, 16]  # the bake's
