"""Fluid texturing in real Blender with the installed addon."""


def test_bake_volume_and_textured_surface(blender, tmp_path):
    r = blender.run("bake_fluid.py", tmp_path)
    assert "FLUID BLENDER OK" in r.stdout
