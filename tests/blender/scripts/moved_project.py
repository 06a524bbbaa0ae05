"""A project moved with its bakes (another machine, a farm's mount) still finds them: phase
"bake" bakes a fluid into the default relative cache, and the fixture effect into an absolute
one made relative afterwards as the farm's wiring step does (paths.make_relative), and a second
plane "Pane" into the relative cache, resumed after its Cache Folder was set to an absolute one
(the resume continues where the bake is, and keeps its record relative), and saves; phase
"check", on the moved copy, finds every frame, volume and image sequence there."""
import os

import bpy

import in_blender
import fixture_wave

in_blender.enable()
fixture_wave.install()
from hydrobake.blender import jobs, paths  # noqa: E402

phase, where = in_blender.args()[:2]
if phase == "bake":
    bpy.ops.wm.save_as_mainfile(filepath=os.path.join(where, "project.blend"))
    domain, fill, s = in_blender.dam_break((16, 8, 8), frames=(1, 3))
    wave = in_blender.new_plane("Glass").hydrobake_testwave
    farm_cache = os.path.join(where, "farm_cache")
    wave.enabled, wave.cache_dir = True, farm_cache
    pane_obj = in_blender.new_plane("Pane")
    pane_obj.data.materials.append(bpy.data.materials.new("PaneMat"))  # (not Glass's)
    pane = pane_obj.hydrobake_testwave
    pane.enabled = True
    bpy.context.scene.frame_start, bpy.context.scene.frame_end = 1, 3
    for name, effect in (("Domain", "fluid"), ("Glass", "testwave"), ("Pane", "testwave")):
        assert bpy.ops.hydrobake.bake(effect=effect, object_name=name) == {"FINISHED"}
    pane.cache_dir = os.path.join(where, "elsewhere_cache", "")
    assert bpy.ops.hydrobake.bake(effect="testwave", object_name="Pane", resume=True) == \
        {"FINISHED"}
    assert pane["bake_folder"].startswith("//"), pane["bake_folder"]  # (it was absolute)
    assert bpy.data.images["HBK_Pane_wave"].filepath.startswith("//")
    assert s["bake_folder"].startswith("//"), s["bake_folder"]  # stored relative
    assert wave["bake_folder"].startswith(farm_cache)  # absolute, as set
    paths.make_relative(farm_cache)
    assert wave["bake_folder"].startswith("//"), wave["bake_folder"]
    bpy.ops.wm.save_mainfile()
    print("MOVED PROJECT BAKED")
else:
    assert bpy.data.filepath.startswith(where)
    bpy.context.scene.frame_set(2)
    for name, effect in (("Domain", "fluid"), ("Glass", "testwave"), ("Pane", "testwave")):
        settings = getattr(bpy.data.objects[name], f"hydrobake_{effect}")
        assert settings.bake_folder.startswith(where), settings.bake_folder
        assert jobs.bake_state(bpy.data.objects[name], effect) == "COMPLETE"
    assert len(bpy.data.objects["HBK_Domain_surface"].data.vertices) > 0
    for block in (*bpy.data.volumes, *bpy.data.images):
        if block.filepath:
            path = bpy.path.abspath(block.filepath)
            assert path.startswith(where) and os.path.isfile(path), (block.name, path)
    assert any(img.name.startswith("HBK_Glass") for img in bpy.data.images)
    print("MOVED PROJECT OK")
