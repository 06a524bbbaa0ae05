"""The caustics effect in real Blender with the installed addon."""
import os

from hydrobake_paths import ROOT


def test_bake_wire_render_free_on_examples(blender, tmp_path):
    r = blender.run("bake_caustics.py", tmp_path, blend=os.path.join(ROOT, "examples.blend"))
    assert "CAUSTICS BLENDER OK" in r.stdout


def test_ground_image_and_a_pouring_source(blender, tmp_path):
    r = blender.run("caustics_sources.py", tmp_path)
    assert "CAUSTICS SOURCES OK" in r.stdout


def test_a_pool_turned_about_z_gets_its_own_grid_and_wiring(blender, tmp_path):
    r = blender.run("caustics_turned.py", tmp_path)
    assert "CAUSTICS TURNED OK" in r.stdout


def test_two_pools_over_one_floor_each_wire_their_own_map(blender, tmp_path):
    r = blender.run("caustics_two_pools.py", tmp_path)
    assert "CAUSTICS TWO POOLS OK" in r.stdout


def test_free_gives_the_scene_back_and_the_wiring_fits_the_artists_materials(blender, tmp_path):
    r = blender.run("caustics_free.py", tmp_path)
    assert "CAUSTICS FREE OK" in r.stdout
