"""The snow effect in real Blender with the installed addon."""
import os

from hydrobake_paths import ROOT


def test_bake_person_wire_free_on_examples(blender, tmp_path):
    r = blender.run("bake_snow.py", tmp_path, blend=os.path.join(ROOT, "examples.blend"))
    assert "SNOW BLENDER OK" in r.stdout


def test_box_mode_projects_the_atlas_back(blender, tmp_path):
    r = blender.run("snow_box.py", tmp_path, blend=os.path.join(ROOT, "examples.blend"))
    assert "SNOW BOX OK" in r.stdout
