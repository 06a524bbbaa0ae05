"""Free Bake puts materials back as they were, whatever happened since the bake (the monkey
test's findings): a hidden object or one in no view layer, a baked material taken out of its
slot, a material the bake made shown by a Shift+D copy, shared materials (one without nodes,
one gone from the file before the Free) and their copies, a material named as a copy would be."""
import pytest

CASES = ("hidden", "slot_changed", "copy_made", "copy_made_copy_first", "copy_made_rebaked",
         "copy_made_original_deleted", "copy_made_swapped", "copy_original_deleted",
         "shared_two", "copy_rebake", "copy_free_rebake", "shared_nodeless",
         "shared_nodeless_pool", "shared_vanished", "floor_replaced", "pool_over_pool",
         "ground_copy_baked", "copy_made_original_deleted_removed",
         "shared_vanished_other_wired", "slot_link_object", "slot_link_data", "slot_link_rebake",
         "linked_copies",
         "linked_pool", "linked_pool_copied", "floor_taken_off",
         "copy_hidden_by_link", "made_hidden_in_copy",
         "copy_hidden_in_freed_copy", "linked_copy_of_baked",
         "linked_copy_then_copy", "made_copy_deleted_baked", "made_under_own_bake",
         "made_behind_copy_link", "linked_copy_deleted_baked",
         "linked_copy_deleted_floor_shared", "linked_copy_made_deleted",
         "linked_copies_own_glass", "two_effects_one_shader", "two_effects_one_shader_lifo",
         "made_slot_removed_copy", "linked_copy_own_made_deleted",
         "made_slot_removed_copy_marked", "linked_copy_slot_removed",
         "linked_copy_slot_removed_copied", "linked_copy_own_slots_kept",
         "copy_name_taken", "linked_copy_slot_removed_then_copied",
         "linked_copy_in_mesh_slot", "made_copy_dropped",
         "linked_copy_given_own_slot", "made_deleted_dropped",
         "made_deleted_dropped_own_mesh", "made_slot_tidied_copies",
         "linked_copy_shows_deleted", "refilled_slot_of_deleted")


@pytest.mark.parametrize("case", CASES)
def test_free_restores(blender, tmp_path, case):
    r = blender.run("free_restores.py", tmp_path, case, check=False)
    assert f"FREE RESTORES {case} OK" in r.stdout, \
        f"exit {r.returncode}\n--- stdout\n{r.stdout[-4000:]}\n--- stderr\n{r.stderr[-3000:]}"
    assert r.returncode == 0
