"""Windshield rain in real Blender with the installed addon."""
import os

from hydrobake_paths import ROOT


def test_bake_windshield_wire_free_on_examples(blender, tmp_path):
    r = blender.run("bake_rain.py", tmp_path, blend=os.path.join(ROOT, "examples.blend"))
    assert "RAIN BLENDER OK" in r.stdout


def test_panes_sharing_a_material_keep_their_own_drops(blender, tmp_path):
    r = blender.run("shared_material.py", tmp_path)
    assert "SHARED MATERIAL OK" in r.stdout


def test_glasses_cars_and_wipers_as_artists_make_them(blender, tmp_path):
    r = blender.run("rain_glass_cases.py", tmp_path)
    assert "RAIN GLASS CASES OK" in r.stdout
