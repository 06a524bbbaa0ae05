"""Fluid texturing in real Blender with the installed addon."""


def test_bake_volume_and_textured_surface(blender, tmp_path):
    r = blender.run("bake_fluid.py", tmp_path)
    assert "FLUID BLENDER OK" in r.stdout and "FLUID PANEL OK" in r.stdout


def test_paint_with_an_empty_and_capture_a_feature_rule(blender, tmp_path):
    r = blender.run("fluid_paint.py", tmp_path)
    assert "FLUID PAINT OK" in r.stdout


def test_mantaflow_liquid_cache_drives_the_textures(blender, tmp_path):
    r = blender.run("fluid_mantaflow.py", tmp_path)
    assert "FLUID MANTAFLOW OK" in r.stdout


def test_mantaflow_time_scale_slows_the_textures_as_it_slows_the_liquid(blender, tmp_path):
    r = blender.run("fluid_mantaflow.py", tmp_path, "0.5")
    assert "FLUID MANTAFLOW TIME SCALE OK" in r.stdout


def test_builtin_samples_repeat_every_uvw_unit(blender, tmp_path):
    r = blender.run("tileable_period.py", tmp_path)
    assert "TILEABLE OK" in r.stdout, r.stdout


def test_frames_without_fluid_and_bad_inputs_named(blender, tmp_path):
    r = blender.run("fluid_edges.py", tmp_path)
    assert "FLUID EMPTY FRAMES OK" in r.stdout and "FLUID REFUSALS OK" in r.stdout, r.stdout
    said = [line for line in r.stdout.splitlines() if line.startswith("Hydrobake: AAA broken")]
    assert len(said) == 1 and said[0].startswith("Hydrobake: AAA broken: frame 4: damaged file (") \
        and said[0].endswith("); Resume the bake to bake it again"), r.stdout[-3000:]


def test_paint_captured_from_the_surface_lands_where_it_was_painted(blender, tmp_path):
    r = blender.run("fluid_capture_paint.py", tmp_path)
    assert "FLUID CAPTURE SELECTION OK" in r.stdout and "FLUID CAPTURE WEIGHTS OK" in r.stdout


def test_ui_capture_paint_asks_in_a_dialog(blender, tmp_path):
    r = blender.run_ui("ui_fluid_capture.py", tmp_path)
    assert "UI FLUID CAPTURE OK" in r.stdout


def test_a_turned_mantaflow_domain_gives_the_world_velocity(blender, tmp_path):
    r = blender.run("fluid_turned_liquid.py", tmp_path)
    assert "FLUID TURNED LIQUID OK" in r.stdout, r.stdout


def test_strokes_obstacles_and_renamed_objects(blender, tmp_path):
    r = blender.run("fluid_strokes_and_names.py", tmp_path)
    for part in ("STROKES", "RENAMED DOMAIN", "RENAMED OBJECTS", "DERIVED"):
        assert f"FLUID {part} OK" in r.stdout, r.stdout


def test_a_keyed_obstacle_is_followed_frame_by_frame(blender, tmp_path):
    r = blender.run("fluid_moving_obstacles.py", tmp_path)
    assert "FLUID MOVING OBSTACLES OK" in r.stdout


def test_a_turned_obstacle_is_a_turned_box(blender, tmp_path):
    r = blender.run("fluid_turned_obstacles.py", tmp_path)
    for part in ("TURNED RAMP", "TURNING PADDLE", "MIRRORED AND SHEARED"):
        assert f"FLUID {part} OK" in r.stdout, r.stdout


def test_a_mesh_obstacle_is_its_shape(blender, tmp_path):
    r = blender.run("fluid_mesh_obstacles.py", tmp_path)
    for part in ("FIELD", "RING", "MOVING", "NORMALS", "BOXES"):
        assert f"FLUID MESH {part} OK" in r.stdout, r.stdout


def test_a_curve_text_or_metaball_obstacle_is_its_shape(blender, tmp_path):
    r = blender.run("fluid_shaped_obstacles.py", tmp_path)
    for part in ("FIELD", "RING", "KINDS", "DEFORMING", "FAMILY", "FAMILY MOVING"):
        assert f"FLUID CURVE {part} OK" in r.stdout, r.stdout


def test_the_fill_object_is_filled_by_its_shape(blender, tmp_path):
    r = blender.run("fluid_fill_shapes.py", tmp_path)
    for part in ("BOX", "BALL", "TORUS", "METABALLS", "OPEN", "UNEVALUATED", "THROWN",
                 "BAKED"):
        assert f"FLUID FILL {part} OK" in r.stdout, r.stdout


def test_every_object_of_the_inflows_and_outflows_collections_pours_or_drains(blender,
                                                                              tmp_path):
    r = blender.run("fluid_inflows.py", tmp_path)
    for part in ("INPUTS", "ONCE", "BAKED"):
        assert f"FLUID INFLOWS {part} OK" in r.stdout, r.stdout
    assert "FLUID OUTFLOWS BAKED OK" in r.stdout, r.stdout


def test_a_planar_inflow_pours_from_the_sheet_around_its_faces(blender, tmp_path):
    r = blender.run("fluid_planar.py", tmp_path)
    for part in ("SHEET", "NORMAL", "BENT", "OUTFLOW", "BAKED"):
        assert f"FLUID PLANAR {part} OK" in r.stdout, r.stdout


def test_the_outflow_drains_the_water_entering_its_shape(blender, tmp_path):
    r = blender.run("fluid_outflow.py", tmp_path)
    for part in ("INPUTS", "REFUSED", "BAKED", "TAP"):
        assert f"FLUID OUTFLOW {part} OK" in r.stdout, r.stdout


def test_the_inflow_pours_from_its_shape_in_its_frames(blender, tmp_path):
    r = blender.run("fluid_inflow.py", tmp_path)
    for part in ("FRAMES", "FOLLOWED", "REFUSED", "BAKED", "DRY START", "CAPPED", "SPRINKLER",
                 "KEYED"):
        assert f"FLUID INFLOW {part} OK" in r.stdout, r.stdout
    # the operator's report of it, and the command line's
    assert "Domain fluid: the inflow stopped pouring at frame 4" in r.stdout + r.stderr
    assert "Domain: the inflow will stop pouring at about frame" in r.stdout + r.stderr
    r = blender.run("cli.py", "bake", "--objects", "Domain", "--effects", "fluid",
                    "--output", tmp_path / "cli", "--no-save", blend=tmp_path / "inflow.blend")
    assert "hydrobake: Domain/fluid note: the inflow stopped pouring at frame 4" in r.stderr, \
        r.stderr
    assert "hydrobake: Domain/fluid warning: Domain: the inflow will stop pouring at about " \
        "frame" in r.stderr, r.stderr
