"""The batch command line in background mode: bake, progress lines, exit codes, kill safety,
signals, argument and override checks, bake folder names."""
import hashlib
import json
import os
import shutil
import signal
import subprocess
import time

import pytest

from hydrobake_paths import ROOT, frames_in, override_cases


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
    # A manifest edited by hand out of shape: free keeps what it names, and says so.
    folder = out / "shot" / "Rear_testwave"
    m = json.loads((folder / "manifest.json").read_text())
    m["frames"]["2"] = None
    (folder / "manifest.json").write_text(json.dumps(m))
    r = blender.run("cli_fixture.py", "free", "--objects", "Rear", "--effects", "testwave",
                    blend=blend)
    assert "Rear/testwave freed 0 files" in r.stdout, r.stdout
    assert "manifest.json: unreadable manifest (frame 2: not a list of files): its files are " \
        "kept (delete the folder by hand)" in r.stderr, r.stderr
    assert sorted(p.name for p in folder.iterdir()) == ["manifest.json"] + [
        f"shot_Rear_testwave_wave_{i:04d}.exr" for i in (2, 3, 4, 5)]


def test_errors_exit_non_zero_with_the_message_on_stderr(blender, tmp_path):
    blend = _blend(blender, tmp_path)
    r = blender.run("cli_fixture.py", "bake", "--effects", "nope", blend=blend, check=False)
    assert r.returncode == 1 and "--effects nope: not an effect" in r.stderr
    r = blender.run("cli_fixture.py", "bake", "--objects", "Missing", blend=blend, check=False)
    assert r.returncode == 1 and "--objects Missing" in r.stderr
    for frames in ("9-2", "5-", "1-1048575"):  # the last ran on for ever, past Blender's end
        r = blender.run("cli_fixture.py", "bake", "--frames", frames, blend=blend, check=False)
        assert r.returncode != 0 and f"--frames '{frames}'" in r.stderr, r.stderr
    assert "need 0 <= START <= END <= 1048574 (Blender's last frame)" in r.stderr, r.stderr
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


def _recorded_and_whole(folder):
    """The manifest's frames, each of whose files is on disk with its recorded SHA-256."""
    m = json.loads((folder / "manifest.json").read_text())
    for files in m["frames"].values():
        for name, digest in files.items():
            assert hashlib.sha256((folder / name).read_bytes()).hexdigest() == digest, name
    return m, sorted(int(f) for f in m["frames"])


@pytest.mark.parametrize("sig, code", [(signal.SIGINT, 130), (signal.SIGTERM, 143)],
                         ids=["SIGINT", "SIGTERM"])
def test_a_signal_cancels_the_bake_cleanly_and_resume_completes_it(blender, tmp_path, sig,
                                                                    code):
    blend = _blend(blender, tmp_path)
    out = tmp_path / "cache"
    args = ("--objects", "Glass,Rear", "--effects", "testwave", "--frames", "1-20",
            "--output", out)
    # Every step after the first spends about 25 s in one C call that polls the cancel flag:
    # the signal lands there, so only a handler that runs while C is busy stops it in time.
    blender.env["HBK_FIXTURE_C_SUBSTEPS"] = "100000"
    try:
        p = blender.popen("cli_fixture.py", "bake", *args, blend=blend)
        folder = out / "shot" / "Glass_testwave"
        deadline = time.monotonic() + 60
        while not frames_in(folder) and time.monotonic() < deadline and p.poll() is None:
            time.sleep(0.05)
        time.sleep(0.5)  # into frame 2's C call
        p.send_signal(sig)
        try:
            stdout, stderr = p.communicate(timeout=10)
        except subprocess.TimeoutExpired:
            p.kill()
            p.communicate()
            pytest.fail(f"still baking 10 s after {sig.name}")
    finally:
        del blender.env["HBK_FIXTURE_C_SUBSTEPS"]
    assert p.returncode == code, (p.returncode, stderr[-3000:])
    m, done = _recorded_and_whole(folder)
    assert not m["complete"] and done == list(range(1, len(done) + 1)) and len(done) < 20
    assert f"hydrobake: Glass/testwave: cancelled after frame {done[-1]}" in stderr, stderr
    assert "not started: Rear/testwave" in stderr and "Rear/testwave frame" not in stdout
    assert not (out / "shot" / "Rear_testwave").exists()
    assert not [n for n in os.listdir(folder) if ".tmp" in n]
    assert "Traceback" not in stderr
    # A later resume continues from there and completes both.
    r = blender.run("cli_fixture.py", "resume", *args, blend=blend)
    assert f"Glass/testwave resumed after frame {done[-1]}" in r.stdout, r.stdout
    for obj in ("Glass", "Rear"):
        m, frames = _recorded_and_whole(out / "shot" / f"{obj}_testwave")
        assert m["complete"] and frames == list(range(1, 21))


def test_empty_selections_are_refused(blender, tmp_path):
    blend = _blend(blender, tmp_path)
    out = tmp_path / "cache"
    for option, value in (("--objects", ""), ("--effects", ","), ("--output", "")):
        args = ["--output", out] if option != "--output" else []
        r = blender.run("cli_fixture.py", "bake", option, value, *args, blend=blend,
                        check=False)
        assert r.returncode == 2, (option, r.returncode, r.stderr[-2000:])
        assert f"argument {option}: {option} '{value}': empty" in r.stderr, r.stderr
        assert "frame 1" not in r.stdout
    assert not out.exists()
    assert not (tmp_path / "hydrobake_cache").exists()


def test_bad_threads_and_an_unwritable_file_get_a_message_not_a_traceback(blender, tmp_path):
    blend = _blend(blender, tmp_path)
    out = tmp_path / "cache"
    for value in ("-1", "abc", "2000"):
        r = blender.run("cli_fixture.py", "bake", "--threads", value, "--output", out,
                        blend=blend, check=False)
        assert r.returncode == 2 and f"--threads '{value}': must be an integer in [0, 1024]" \
            in r.stderr, r.stderr[-2000:]
    # A .blend that cannot be written (Blender writes '<file>@' first, here a folder; file
    # modes do not stop root): the bake is on disk, the save failure is one line.
    os.mkdir(blend + "@")
    r = blender.run("cli_fixture.py", "bake", "--frames", "1-2", "--output", out,
                    blend=blend, check=False)
    assert r.returncode == 1 and "hydrobake: error: could not save" in r.stderr, r.stderr
    assert "Traceback" not in r.stderr and "--no-save" in r.stderr
    assert json.loads((out / "shot" / "Glass_testwave" / "manifest.json").read_text())["complete"]


def test_overrides_are_checked_against_keys_shapes_types_and_ranges(blender, tmp_path):
    blend = str(tmp_path / "examples.blend")
    shutil.copy(os.path.join(ROOT, "examples.blend"), blend)
    water = {"objects": ["Water"], "effects": ["caustics"]}
    cases = [
        # Values Blender would clamp or take as numbers: refused with the range.
        ({"Water/caustics": {"map_resolution": 0}}, "Water/caustics: map_resolution = 0: "
         "must be in [16, 8192]"),
        ({"Water/caustics": {"water": {"substeps": -5}}}, "Water/caustics: water.substeps = "
         "-5: must be in [1, 1000]"),
        ({"Water/caustics": {"water": {"substeps": True}}}, "water.substeps = true: must be an "
         "integer in [1, 1000], not true/false"),
        ({"Water/caustics": {"water": {"gravity": False}}}, "water.gravity = false: must be a "
         "number in [0.01, 100], not true/false"),
        ({"*/caustics": {"water": {"gravity": 1e9}}}, "*/caustics: water.gravity = 1000000000.0: "
         "must be in [0.01, 100]"),
        ('{"Water/caustics": {"water": {"gravity": NaN}}}', "water.gravity = NaN: must be in"),
        ({"Water/caustics": {"light": {"light_direction": [0, 0, 1e40]}}},
         "light.light_direction = [0, 0, 1e+40]: must be in"),
        # A value where a group belongs and a group where a value does.
        ({"Water/caustics": {"water": 5}}, "Water/caustics: water is a group of settings"),
        ({"Water/caustics": {"map_resolution": {"x": 1}}}, "Water/caustics: map_resolution is "
         "a single setting, not a group"),
        # Keys that name no object, no effect, or have no slash.
        ({"Nope/caustics": {}}, "key 'Nope/caustics': no object 'Nope'"),
        ({"Water/caustic": {}}, "key 'Water/caustic': 'caustic' is not an effect"),
        ({"Water": {}}, "key 'Water': must be \"Object/effect\" or \"*/effect\""),
        ({"Camera/caustics": {"map_resolution": 32}},
         "key 'Camera/caustics': Camera cannot have the caustics effect"),
        # The bake's own record is not a parameter: put back after the run, an override of
        # it left a bake without its folder, or on disk but not marked baked (found by a
        # fuzzer of --overrides).
        ({"Water/caustics": {"bake_folder": "abc"}}, "Water/caustics: bake_folder cannot be "
         "set: it is the bake's record (use --output for where bakes go)"),
        ({"*/caustics": {"is_baked": True}}, "*/caustics: is_baked cannot be set: it is the "
         "bake's record"),
        ({"Water/caustics": {"enabled": False}}, "enabled cannot be set: choose what is baked "
         "with --objects and --effects"),
        ({"Water/caustics": {"name": "x"}}, "name cannot be set: it is not a parameter"),
        # A data-block setting by name, checked as the panel checks it (Python's setattr
        # would put a camera in as the pool's ground, and the bake fail with a traceback).
        ({"Water/caustics": {"ground_object": "Camera"}}, 'Water/caustics: ground_object = '
         '"Camera": Camera cannot be the Ground, which takes a mesh other than the water itself'),
        ({"Water/caustics": {"ground_object": "Water"}}, "Water cannot be the Ground"),
        ({"Water/caustics": {"sun_object": "Ground"}}, "Ground cannot be the Sun, which takes "
         "a sun lamp"),
        ({"Water/caustics": {"ground_object": "Nope"}}, 'ground_object = "Nope": no Object of '
         "that name in"),
        ({"Water/caustics": {"ground_image": "Nope"}}, "no Image of that name"),
        ({"Water/caustics": {"ground_object": 3}}, "expected a Object type, not int"),
        # What is right goes through: the bounds themselves (float32 in Blender), wildcards,
        # other effects' keys, objects not baked this run.
        ({"Water/caustics": {"map_resolution": 16, "water": {"gravity": 0.01,
                                                             "substeps": 1000}}}, None),
        ({"*/caustics": {"water": {"gravity": 100.0}}, "*/snow": {"snow": {}},
          "Tank/fluid": {"fluid": {"substeps": 2}}}, None),
        ({"Water/caustics": {"ground_object": "Ground", "sun_object": "Sun",
                             "disturber_object": None}}, None),
    ]
    lines = override_cases(blender, blend, water, cases, tmp_path)
    valid = "valid keys: Car/snow, Ground/snow, Person/snow, Tank/fluid, Water/caustics, " \
        "Windshield/rain, */caustics, */fluid, */rain, */snow"
    assert all(valid in l for l in lines[9:13]), lines[9:13]
    shown = tmp_path / "shown.json"  # a by-name value is the data-block while the run lasts
    shown.write_text(json.dumps([dict(water, table={"Water/caustics": {
        "ground_object": "Ground"}}, show="ground_object")]))
    r = blender.run("cli_overrides.py", shown, blend=blend)
    assert "SHOW Water/caustics ground_object Ground" in r.stdout, r.stdout[-2000:]
    assert "AFTER Water/caustics ground_object Pool Floor" in r.stdout, r.stdout[-2000:]
    # Through the command line: one error line naming the key, no traceback, nothing baked.
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps({"Water/caustics": {"water": 5}}))
    r = blender.run("cli.py", "bake", "--objects", "Water", "--effects", "caustics",
                    "--overrides", bad, "--output", tmp_path / "cache", blend=blend,
                    check=False)
    assert r.returncode == 1 and "Traceback" not in r.stderr, r.stderr[-3000:]
    assert "hydrobake: error: --overrides Water/caustics: water is a group" in r.stderr
    assert not (tmp_path / "cache").exists()


def test_invalid_json_names_the_overrides_file(blender, tmp_path):
    blend = _blend(blender, tmp_path)
    bad = tmp_path / "typo.json"
    bad.write_text('{"*/testwave": {"frame_start": 2,}}')
    r = blender.run("cli_fixture.py", "bake", "--overrides", bad, blend=blend, check=False)
    assert r.returncode == 1 and "Traceback" not in r.stderr
    assert f"hydrobake: error: --overrides {bad}: not valid JSON" in r.stderr, r.stderr


def test_a_relative_output_is_recorded_absolute(blender, tmp_path):
    blend = _blend(blender, tmp_path)
    here, elsewhere = tmp_path / "here", tmp_path / "elsewhere"
    here.mkdir()
    elsewhere.mkdir()
    blender.run("cli_fixture.py", "bake", "--objects", "Glass", "--effects", "testwave",
                "--frames", "1-2", "--output", "cache", blend=blend, cwd=here)
    folder = here / "cache" / "shot" / "Glass_testwave"
    assert frames_in(folder) == [1, 2]
    # Another run, started from another folder, finds the bake the file records.
    r = blender.run("cli_fixture.py", "list", blend=blend, cwd=elsewhere)
    assert f"Glass/testwave: enabled=True baked=True folder={folder}" in r.stdout, r.stdout
    r = blender.run("cli_fixture.py", "free", "--objects", "Glass", "--effects", "testwave",
                    blend=blend, cwd=elsewhere)
    assert "Glass/testwave freed 3 files" in r.stdout, r.stdout
    assert not folder.exists()


def test_a_target_that_cannot_be_set_up_does_not_stop_the_others(blender, tmp_path):
    blend = str(tmp_path / "shot.blend")
    blender.run("make_fixture_blend.py", blend, "!Broken")  # first in name order
    out = tmp_path / "cache"
    r = blender.run("cli_fixture.py", "bake", "--frames", "1-2", "--output", out, blend=blend,
                    check=False)
    assert r.returncode == 1 and "Traceback" not in r.stderr, r.stderr[-3000:]
    assert "hydrobake: Broken/testwave failed: Broken: the fixture cannot be set up here" \
        in r.stderr, r.stderr
    for obj in ("Glass", "Rear"):
        assert f"hydrobake: {obj}/testwave finished" in r.stdout
        assert frames_in(out / "shot" / f"{obj}_testwave") == [1, 2]
    assert not (out / "shot" / "Broken_testwave").exists()


def test_names_that_clean_to_the_same_folder_get_their_own(blender, tmp_path):
    blend = str(tmp_path / "shot.blend")
    blender.run("make_fixture_blend.py", blend, "Pool.A", "Pool_A", "Pool A")
    out = tmp_path / "cache"
    blender.run("cli_fixture.py", "bake", "--objects", "Pool.A,Pool_A,Pool A", "--effects",
                "testwave", "--frames", "1-2", "--output", out, blend=blend)
    folders = {}
    for name in ("Pool.A", "Pool_A", "Pool A"):  # a clean name keeps its folder name
        tag = "" if name == "Pool_A" else "_" + hashlib.sha1(name.encode()).hexdigest()[:6]
        folders[name] = out / "shot" / f"Pool_A{tag}_testwave"
    assert len(set(folders.values())) == 3
    for name, folder in folders.items():
        m, frames = _recorded_and_whole(folder)
        assert m["complete"] and m["object"] == name and frames == [1, 2]


def test_resume_refuses_a_changed_map_resolution(blender, tmp_path):
    blend = str(tmp_path / "pool.blend")
    shutil.copy(os.path.join(ROOT, "examples.blend"), blend)

    def run(command, resolution, frames):
        table = tmp_path / f"map{resolution}.json"
        table.write_text(json.dumps({"Water/caustics": {"map_resolution": resolution,
                                                        "water": {"width": 24}}}))
        return blender.run("cli.py", command, "--objects", "Water", "--effects", "caustics",
                           "--frames", frames, "--overrides", table, "--output",
                           tmp_path / "cache", "--no-save", blend=blend, check=False)
    assert run("bake", 32, "1-2").returncode == 0
    folder = tmp_path / "cache" / "pool" / "Water_caustics"
    w, h = json.loads((folder / "manifest.json").read_text())["inputs"]["map_size"]
    r = run("resume", 16, "1-3")
    assert r.returncode == 1 and "Traceback" not in r.stderr, r.stderr[-3000:]
    assert f"map_size: [{w}, {h}] in the bake, [16, " in r.stderr, r.stderr
    assert frames_in(folder) == [1, 2]
    r = run("resume", 32, "1-3")
    assert r.returncode == 0 and "resumed after frame 2" in r.stdout
    assert frames_in(folder) == [1, 2, 3]


def test_the_shipped_command_runs_quietly(blender, tmp_path):
    """build/hydrobake-batch itself (the tests' scripts enable the addon their own way): no
    reload of the addon on the way in, the listing, exit 0."""
    blend = _blend(blender, tmp_path)
    r = subprocess.run([os.path.join(ROOT, "build", "hydrobake-batch"), blend, "list"],
                       env=blender.env, capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr[-2000:]
    assert "module changed on disk" not in r.stdout + r.stderr, r.stdout[-2000:]
    assert "effects: caustics, fluid, rain, snow" in r.stdout and "Traceback" not in r.stderr


def test_an_object_name_with_a_comma_is_taken_whole(blender, tmp_path):
    """--objects splits at commas; a name holding one ("Wall, North") could not be given."""
    blend = str(tmp_path / "shot.blend")
    blender.run("make_fixture_blend.py", blend, "Wall, North", "Wall", "Gate")
    r = blender.run("cli_fixture.py", "bake", "--objects", "Wall, North,Gate", "--effects",
                    "testwave", "--frames", "1-1", "--output", tmp_path / "cache", blend=blend)
    assert "hydrobake: Wall, North/testwave finished" in r.stdout, r.stdout[-2000:]
    assert "hydrobake: Gate/testwave finished" in r.stdout
    assert "hydrobake: Wall/testwave" not in r.stdout  # the longest name that matches wins
    r = blender.run("cli_fixture.py", "bake", "--objects", "Wall,Gate", "--effects", "testwave",
                    "--frames", "1-1", "--output", tmp_path / "cache", blend=blend)
    assert "hydrobake: Wall/testwave finished" in r.stdout and "Wall, North/" not in r.stdout
