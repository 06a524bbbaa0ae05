"""The real Blender UI while Bake runs modal (under Xvfb): renames, Save As, wiring errors,
another file opened, Cancel and Resume, with snow, rain and the fluid."""


def test_ui_edits_while_baking_keep_each_bake_on_its_object(blender, tmp_path):
    r = blender.run_ui("ui_bake_while_editing.py", tmp_path, timeout=300)
    out = r.stdout + r.stderr
    assert "UI BAKE WHILE EDITING OK" in r.stdout, out[-4000:]
    # An error wiring a bake is the operator's report, not an exception out of modal().
    assert "Error: Python: Traceback" not in out, out[-4000:]
