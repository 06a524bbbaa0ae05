"""The snow effect in real Blender with the installed addon."""
import os

from hydrobake_paths import ROOT

from hydrobake.core.snow import Snow


def test_bake_person_wire_free_on_examples(blender, tmp_path):
    r = blender.run("bake_snow.py", tmp_path, blend=os.path.join(ROOT, "examples.blend"))
    assert "SNOW BLENDER OK" in r.stdout


def test_box_mode_projects_the_atlas_back(blender, tmp_path):
    r = blender.run("snow_box.py", tmp_path, blend=os.path.join(ROOT, "examples.blend"))
    assert "SNOW BOX OK" in r.stdout


def test_bench_script_refuses_bad_arguments(blender):
    """build/bench_snow_blender.py stops before building its mesh: exit 2, naming the
    argument and the flake count's range as the addon's property has it."""
    flakes = Snow.spec().by_name["flake_count"]
    script = os.path.join(ROOT, "build", "bench_snow_blender.py")
    r = blender.run(script, 1, 0, check=False)
    assert r.returncode == 2, r.stdout + r.stderr
    assert (f"FLAKES must be an integer in [{int(flakes.min)}, {int(flakes.max)}], got '0'"
            in r.stderr)
    r = blender.run(script, "x", check=False)
    assert r.returncode == 2 and "FRAMES must be an integer in [1, 1048574], got 'x'" in r.stderr
