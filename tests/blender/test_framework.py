"""The bake framework inside real Blender, with the addon installed from its zip."""
import os
import shutil

import pytest

from hydrobake_paths import ROOT


def test_install_from_zip_enable_and_disable(blender):
    # The session fixture did it; run it again to check overwrite-install works too.
    from hydrobake_paths import addon_zip
    r = blender.run("install_addon.py", addon_zip())
    assert "HYDROBAKE INSTALLED" in r.stdout


def test_bake_wire_cancel_free(blender, tmp_path):
    r = blender.run("bake_fixture.py", tmp_path)
    assert "BAKE FIXTURE OK" in r.stdout
    assert "manifest.json: unreadable manifest (frame 1: not a list of files): its files are " \
        "kept (delete the folder by hand)" in r.stdout, r.stdout[-3000:]


def test_written_vdb_loads_as_a_volume_object(blender, tmp_path):
    r = blender.run("vdb_volume.py", tmp_path)
    assert "VDB VOLUME OK" in r.stdout


def test_ui_bake_is_modal_and_esc_cancels(blender, tmp_path):
    r = blender.run_ui("ui_modal_cancel.py", tmp_path)
    assert "UI MODAL CANCEL OK" in r.stdout


def test_ui_reading_the_scene_shows_progress_unless_another_bake_does(blender, tmp_path):
    r = blender.run_ui("ui_reading_progress.py", tmp_path)
    assert "UI READING PROGRESS OK" in r.stdout


def test_ui_esc_stops_a_bake_while_it_reads_the_scene(blender, tmp_path):
    r = blender.run_ui("ui_reading_cancel.py", tmp_path)
    assert "UI READING CANCEL OK" in r.stdout, r.stdout
    print(next(ln for ln in r.stdout.splitlines() if ln.startswith("UI reading cancelled")))


def test_ui_addon_disabled_while_baking_keeps_frames_and_lets_go(blender, tmp_path):
    r = blender.run_ui("ui_disable_midbake.py", tmp_path)
    assert "UI DISABLE MIDBAKE OK" in r.stdout


def test_a_bake_in_another_scene_reads_that_scene_animation(blender, tmp_path):
    r = blender.run("other_scene.py", tmp_path, blend=os.path.join(ROOT, "examples.blend"))
    assert "OTHER SCENE OK" in r.stdout


@pytest.mark.parametrize("scene", ["Rain", "Fluid"])
def test_a_bake_of_the_scene_given_on_the_command_line_reads_its_animation(blender, tmp_path,
                                                                           scene):
    r = blender.run("scene_from_command_line.py", blend=os.path.join(ROOT, "examples.blend"),
                    extra=("--scene", scene))
    assert f"COMMAND LINE SCENE OK {scene}" in r.stdout


def test_a_project_moved_with_its_bakes_still_finds_them(blender, tmp_path):
    first, moved = tmp_path / "first", tmp_path / "moved"
    first.mkdir()
    assert "MOVED PROJECT BAKED" in blender.run("moved_project.py", "bake", first).stdout
    shutil.copytree(first, moved)
    shutil.rmtree(first)
    r = blender.run("moved_project.py", "check", moved, blend=str(moved / "project.blend"))
    assert "MOVED PROJECT OK" in r.stdout


def test_a_file_saved_elsewhere_or_appended_still_finds_its_bakes(blender, tmp_path):
    assert "SAVED ELSEWHERE BAKED" in blender.run("saved_elsewhere.py", tmp_path, "bake").stdout
    r = blender.run("saved_elsewhere.py", tmp_path, "check")
    assert "SAVED ELSEWHERE OK" in r.stdout


def test_saved_without_remap_over_an_older_bake_still_shows_its_own(blender, tmp_path):
    r = blender.run("saved_over_older_bake.py", tmp_path)
    assert "SAVED OVER OLDER BAKE OK" in r.stdout


def test_a_rebake_after_pack_resources_shows_the_new_bake_not_the_packed_one(blender, tmp_path):
    r = blender.run("packed_rebake.py", tmp_path)
    assert "PACKED REBAKE OK" in r.stdout


def test_unpack_resources_gives_each_bake_its_own_file(blender, tmp_path):
    r = blender.run("packed_unpack.py", tmp_path)
    assert "PACKED UNPACK OK" in r.stdout


def test_a_bake_from_before_file_tags_resumes_and_shows_under_its_names(blender, tmp_path):
    r = blender.run("old_file_names.py", tmp_path)
    assert "OLD FILE NAMES OK" in r.stdout


def test_a_free_leaves_another_bakes_material_the_artist_gave_the_object(blender, tmp_path):
    r = blender.run("given_wiring.py", tmp_path)
    assert "GIVEN WIRING OK" in r.stdout


def test_a_free_leaves_what_an_alt_d_copy_shows_in_the_mesh_slot_its_link_hid(blender, tmp_path):
    r = blender.run("hidden_copy_shown.py", tmp_path)
    assert "HIDDEN COPY SHOWN OK" in r.stdout


def test_free_puts_back_a_shared_material_the_artist_renamed_meanwhile(blender, tmp_path):
    r = blender.run("renamed_shared.py", tmp_path)
    assert "RENAMED SHARED OK" in r.stdout


def test_a_copy_of_a_material_whose_nodes_a_bake_turned_on_keeps_them_off_once_clean(
        blender, tmp_path):
    r = blender.run("shared_nodes_off.py", tmp_path)
    assert "SHARED NODES OFF OK" in r.stdout


def test_a_clean_copy_a_free_shows_again_on_an_alt_d_mesh_goes_back_in_that_free(
        blender, tmp_path):
    r = blender.run("revealed_copy.py", tmp_path)
    assert "REVEALED COPY OK" in r.stdout


def test_free_of_a_copy_of_another_objects_copy_switches_the_link_back_only_where_it_was(
        blender, tmp_path):
    r = blender.run("given_copy_link.py", tmp_path)
    assert "GIVEN COPY LINK OK" in r.stdout


def test_copied_records_and_taken_names_leave_the_owners_bake_whole(blender, tmp_path):
    r = blender.run("copied_and_renamed.py", tmp_path)
    assert "COPIED AND RENAMED OK" in r.stdout


def test_a_clean_copy_waits_for_the_shared_materials_other_wiring_whichever_free_comes_first(
        blender, tmp_path):
    r = blender.run("copy_waits_any_effect.py", tmp_path)
    assert "COPY WAITS OK" in r.stdout


def test_a_renamed_objects_waiting_copy_switches_the_link_back_though_its_old_name_is_taken(
        blender, tmp_path):
    r = blender.run("renamed_waiting_copy.py", tmp_path)
    assert "RENAMED WAITING COPY OK" in r.stdout


def test_a_bake_through_lagging_slots_leaves_the_meshs_shared_material_untouched(
        blender, tmp_path):
    r = blender.run("lagging_slot_nodes.py", tmp_path)
    assert "LAGGING SLOT NODES OK" in r.stdout


def test_renamed_helper_objects_are_updated_by_a_rebake_and_taken_out_by_free(blender, tmp_path):
    r = blender.run("renamed_helpers.py", tmp_path)
    assert "RENAMED HELPERS OK" in r.stdout


def test_shared_materials_meshes_and_records_freed_in_any_order(blender, tmp_path):
    r = blender.run("shared_records.py", tmp_path)
    assert "SHARED RECORDS OK" in r.stdout


def test_an_overlapping_uv_map_is_baked_with_a_warning(blender, tmp_path):
    """Snow and rain bake into the UVs: a Mirror modifier's copy sharing them is warned of by
    Job (naming the object, share and map) and reported by the Bake operator; a clean map and
    snow's BOX mode are not."""
    r = blender.run("uv_overlap_warning.py", tmp_path)
    assert "UV OVERLAP WARNING OK" in r.stdout
    assert "Warning: Mirrored: 100% of UV map 'Unwrap' is shared by two or more faces" \
        in r.stdout + r.stderr


def test_an_object_its_view_layer_leaves_out_is_refused_by_name(blender, tmp_path):
    """A glass, collider, ground, disturber or emitter that Show in Viewports, an excluded or
    a disabled collection leaves out is not evaluated (no modifiers, no particles): each bake
    is refused naming it and its setting, with nothing written; closed eyes bake."""
    r = blender.run("hidden_inputs.py", tmp_path)
    assert "HIDDEN INPUTS OK" in r.stdout


def test_free_that_cannot_unwire_keeps_the_files_and_record(blender, tmp_path):
    r = blender.run("free_keeps_on_error.py", tmp_path)
    assert "FREE KEEPS ON ERROR OK" in r.stdout


def test_a_bake_remade_in_another_folder_replaces_the_old_once_complete(blender, tmp_path):
    r = blender.run("superseded_folders.py", tmp_path)
    assert "SUPERSEDED FOLDERS OK" in r.stdout


def test_evaluated_depsgraph_without_context_lookups(blender, tmp_path):
    r = blender.run("depsgraph_evaluated.py", tmp_path)
    assert "DEPSGRAPH EVALUATED OK" in r.stdout


def test_a_deleted_pools_caustics_leave_the_floor(blender, tmp_path):
    r = blender.run("deleted_pool.py", tmp_path)
    assert "DELETED POOL OK" in r.stdout


def test_deleted_objects_bakes_are_shown_and_removed_on_request(blender, tmp_path):
    r = blender.run("deleted_baked.py", tmp_path)
    assert "DELETED BAKED OK" in r.stdout


def test_operator_arguments_that_name_nothing_are_refused_by_name(blender, tmp_path):
    r = blender.run("operator_arguments.py", tmp_path)
    assert "OPERATOR ARGUMENTS OK" in r.stdout


def test_linked_objects_and_overrides_are_baked_in_their_library(blender, tmp_path):
    r = blender.run("linked_objects.py", tmp_path)
    assert "LINKED OBJECTS OK" in r.stdout


def test_a_bake_another_file_made_in_the_folder_is_left_to_it(blender, tmp_path):
    r = blender.run("other_files_bakes.py", tmp_path)
    assert "OTHER FILES BAKES OK" in r.stdout


def test_resume_refuses_a_scene_changed_under_its_kept_frames(blender, tmp_path):
    r = blender.run("resume_changed_scene.py", tmp_path)
    assert "RESUME CHANGED SCENE OK" in r.stdout


def test_shapes_are_read_at_the_bakes_first_frame(blender, tmp_path):
    """Fails with the addon of c460edc: a bake pressed on frame 9 read the shapes there."""
    r = blender.run("first_frame_shapes.py", tmp_path)
    assert "FIRST FRAME SHAPES OK" in r.stdout


def test_a_pools_ground_and_source_and_the_obstacles_are_followed(blender, tmp_path):
    r = blender.run("followed_inputs.py", tmp_path)
    assert "FOLLOWED INPUTS OK" in r.stdout


def test_a_bake_leaves_the_scenes_simulation_caches_alone(blender, tmp_path):
    r = blender.run("cloth_cache_kept.py", tmp_path)
    assert "CLOTH CACHE KEPT OK" in r.stdout
