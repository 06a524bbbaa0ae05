"""The snow effect in real Blender with the installed addon."""
import os

from hydrobake_paths import ROOT, override_cases

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


def test_a_rebake_and_resume_rewire_the_same_nodes(blender, tmp_path):
    """A second Bake and a Resume mix the snow into the material's own shader again (the mix
    was once linked into itself), and Free Bake leaves the material as it was."""
    r = blender.run("snow_rebake.py", tmp_path)
    assert "SNOW REBAKE OK" in r.stdout


def test_a_frame_lasts_one_over_fps(blender, tmp_path):
    """At 60 fps and at 12 fps flakes fall at Fall Speed in scene time (a frame at 60 fps
    simulated 0.04 s, 2.4 times too long); the bake stays deterministic and resumable."""
    r = blender.run("snow_fps.py", tmp_path)
    assert "SNOW FPS OK" in r.stdout


def test_objects_without_a_node_material_get_one_and_free_gives_it_back(blender, tmp_path):
    r = blender.run("snow_no_material.py", tmp_path)
    assert "SNOW NO MATERIAL OK" in r.stdout


def test_free_removes_the_snow_images(blender, tmp_path):
    r = blender.run("snow_free_images.py", tmp_path)
    assert "SNOW FREE IMAGES OK" in r.stdout


def test_snow_depth_is_world_metres_at_any_object_scale(blender, tmp_path):
    """Rendered (Cycles, side view): a slab in centimetres with scale 0.01 gets the same
    snow depth as the slab in metres."""
    r = blender.run("snow_displacement.py", tmp_path)
    assert "SNOW DISPLACEMENT OK" in r.stdout


def test_box_mode_faces_take_their_tile_by_the_world_normal(blender, tmp_path):
    r = blender.run("snow_box_scale.py", tmp_path)
    assert "SNOW BOX SCALE OK" in r.stdout


def test_box_mode_bakes_a_mesh_without_uv_map(blender, tmp_path):
    r = blender.run("snow_box_no_uv.py", tmp_path)
    assert "SNOW BOX NO UV OK" in r.stdout


def test_moving_objects_do_not_depend_on_the_current_frame(blender, tmp_path):
    """The object and its colliders move by their animation over the bake's frames: the
    same bytes whether the scene is on frame 5 or 1 when Bake is pressed."""
    r = blender.run("snow_animated.py", tmp_path)
    assert "SNOW ANIMATED OK" in r.stdout


def test_box_mode_projects_faces_that_modifiers_make(blender, tmp_path):
    """A block mirrored by a Mirror modifier under a roof over its x < 0 half: the projection
    is made on the evaluated mesh, so snow shows at x > 0 only (the mirrored faces showed
    their originals' snow)."""
    r = blender.run("snow_box_mirror.py", tmp_path)
    assert "SNOW BOX MIRROR OK" in r.stdout


def test_snowfall_per_square_metre_does_not_depend_on_the_object_size(blender, tmp_path):
    """Flake Density fills each Auto Volume: a 1 m and an 8 m plate get the same mean depth
    (with the same flake count the big plate got a twentieth); presets set the density; a
    density the kernel cannot hold is refused by name."""
    r = blender.run("snow_density.py", tmp_path)
    assert "SNOW DENSITY OK" in r.stdout


def test_overrides_of_what_auto_volume_sets_are_refused(blender, tmp_path):
    """While Auto Volume is on, the bake sets the volume and the flake count itself: an
    override of them would be dropped without a word, so it is refused, naming what to set."""
    car = {"objects": ["Car"], "effects": ["snow"]}
    cases = [
        ({"Car/snow": {"snow": {"flake_count": 5000}}},
         "Car/snow: snow.flake_count cannot be set for Car: Flake Density (flake_density) "
         "sets it while Auto Volume is on; set auto_volume false to set it"),
        ({"*/snow": {"snow": {"volume_min": [0, 0, 0]}}},
         "*/snow: snow.volume_min cannot be set for Car: Auto Volume fits it"),
        ({"Car/snow": {"flake_density": 0}}, "flake_density = 0: must be in [0.01, "),
        ({"Car/snow": {"flake_density": 100}}, None),
        ({"Car/snow": {"auto_volume": False, "snow": {"flake_count": 5000,
                                                      "volume_max": [9, 9, 9]}}}, None),
    ]
    override_cases(blender, os.path.join(ROOT, "examples.blend"), car, cases, tmp_path)


def test_snow_follows_a_deforming_mesh_frame_by_frame(blender, tmp_path):
    """Fails with the addon of 63dbdf7, which moved the first frame's shape rigidly."""
    r = blender.run("snow_deforming.py", tmp_path)
    assert "SNOW DEFORMING OK" in r.stdout


def test_a_bake_stepping_the_scene_says_how_far_it_has_got(blender, tmp_path):
    r = blender.run("reading_progress.py", tmp_path)
    assert "READING PROGRESS OK 6" in r.stdout
