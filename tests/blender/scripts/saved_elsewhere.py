"""A baked file saved into another folder (File > Save As, Save Copy) or whose baked object is
appended into a file elsewhere still finds its bakes: Blender rebases its own relative paths
(images, volumes) there, and the addon's recorded folders follow. Phase "bake" bakes a fluid
(a mesh sequence, a Volume) and the fixture effect (an image sequence) in ``<tmp>/a`` into the
default relative cache, then saves as ``<tmp>/b/shot.blend`` and a copy as
``<tmp>/c/x/copy.blend``, and with Remap Relative off a copy as ``<tmp>/r/s/norel.blend``
and the file as ``<tmp>/f/g/h.blend``; phase "check" opens each of those, a file in ``<tmp>/d`` that
appends the objects, and one in ``<tmp>/e`` that links them from the project moved whole."""
import os

import bpy

import in_blender
import fixture_wave

in_blender.enable()
fixture_wave.install()
from hydrobake.blender import jobs  # noqa: E402

BAKES = (("Domain", "fluid"), ("Glass", "testwave"))


def assert_found(where, cache):
    """Every bake complete and recorded in ``cache``; the surface and images show it."""
    bpy.context.scene.frame_set(2)
    for name, effect in BAKES:
        settings = getattr(bpy.data.objects[name], f"hydrobake_{effect}")
        assert settings.bake_folder.startswith(cache), (where, name, settings.bake_folder)
        assert jobs.bake_state(bpy.data.objects[name], effect) == "COMPLETE", (where, name)
    assert len(bpy.data.objects["HBK_Domain_surface"].data.vertices) > 0, where
    for block in (*bpy.data.volumes, *bpy.data.images):
        if block.filepath:
            path = os.path.normpath(bpy.path.abspath(block.filepath, library=block.library))
            assert path.startswith(cache) and os.path.isfile(path), (where, block.name, path)


def in_a(record):
    """Whether a record, by itself (relative to the .blend), leads into ``<tmp>/a``: a bake
    folder, a sequence's "kind|folder|stream" or a voxel texture."""
    path = record.split("|")[1] if "|" in record else record
    return os.path.normpath(bpy.path.abspath(path)).startswith(os.path.join(tmp, "a", ""))


def records():
    """(group, key, base key) of every path the file records."""
    surface = bpy.data.objects["HBK_Domain_surface"]
    return [(getattr(bpy.data.objects[n], f"hydrobake_{e}"), "bake_folder", "bake_base")
            for n, e in BAKES] + [
        (surface, "hydrobake_sequence", "hydrobake_sequence_base"),
        (bpy.data.objects["Domain"].hydrobake_fluid.samples[0], "voxel_file",
         "voxel_file_base")]


tmp, phase = in_blender.args()[:2]
cache = os.path.join(tmp, "a", "hydrobake_cache", "")
if phase == "bake":
    os.makedirs(os.path.join(tmp, "a"))
    bpy.ops.wm.save_as_mainfile(filepath=os.path.join(tmp, "a", "project.blend"))
    domain, fill, s = in_blender.dam_break((16, 8, 8), frames=(1, 3))
    with bpy.context.temp_override(object=domain):  # a voxel texture beside the .blend
        assert bpy.ops.hydrobake.fluid_sample(action="ADD") == {"FINISHED"}
        assert bpy.ops.hydrobake.fluid_noise_texture(index=0, size=8) == {"FINISHED"}
    wave = in_blender.new_plane("Glass").hydrobake_testwave
    wave.enabled = True
    bpy.context.scene.frame_start, bpy.context.scene.frame_end = 1, 3
    for name, effect in BAKES:
        assert bpy.ops.hydrobake.bake(effect=effect, object_name=name) == {"FINISHED"}
    bpy.ops.wm.save_mainfile()
    for group, _key, base in records():  # as a file from before the records had bases
        del group[base]
    # The copy one folder deeper, where the records relative to b lead nowhere.
    for sub, copy in (("b", False), (os.path.join("c", "x"), True)):
        os.makedirs(os.path.join(tmp, sub))
        name = "copy.blend" if copy else "shot.blend"
        bpy.ops.wm.save_as_mainfile(filepath=os.path.join(tmp, sub, name), copy=copy)
        assert_found(f"after saving {sub}", cache)  # in the session, before any reopening
        # The session's records follow the file to b, as Blender's paths do (not to c).
        for group, key, base in records():
            assert in_a(group[key]), (sub, group[key])
            assert group[base] == os.path.join(tmp, "b"), (sub, group[base])
    # Remap Relative off: Blender keeps its relative paths as they were (a copy from b, and
    # the session saved as f/g/h.blend); the bakes' images and volumes are found again, in
    # the session and when the files are opened.
    for sub, name, copy in ((os.path.join("r", "s"), "norel.blend", True),
                            (os.path.join("f", "g"), "h.blend", False)):
        os.makedirs(os.path.join(tmp, sub))
        bpy.ops.wm.save_as_mainfile(filepath=os.path.join(tmp, sub, name), copy=copy,
                                    relative_remap=False)
        assert_found(f"after saving {sub} without remapping", cache)
    print("SAVED ELSEWHERE BAKED")
else:
    for blend in ("b/shot.blend", "c/x/copy.blend", "r/s/norel.blend", "f/g/h.blend"):
        bpy.ops.wm.open_mainfile(filepath=os.path.join(tmp, blend))
        assert_found(blend, cache)
    # Saved while the bakes are out of reach (a drive not mounted), b keeps where they are.
    bpy.ops.wm.open_mainfile(filepath=os.path.join(tmp, "b", "shot.blend"))
    os.rename(os.path.join(tmp, "a"), os.path.join(tmp, "unmounted"))
    bpy.ops.wm.save_mainfile()
    os.rename(os.path.join(tmp, "unmounted"), os.path.join(tmp, "a"))
    bpy.ops.wm.open_mainfile(filepath=os.path.join(tmp, "b", "shot.blend"))
    assert_found("b saved with a out of reach", cache)
    bpy.ops.wm.open_mainfile(filepath=os.path.join(tmp, "c", "x", "copy.blend"))
    # Saved again where it is now, the file records the bakes relative to it, as Blender
    # records the images: found by that record alone.
    bpy.ops.wm.save_mainfile()
    for group, key, base in records():
        assert group[key].startswith("//../../a/") or "|//../../a/" in group[key], group[key]
        assert group[base] == os.path.join(tmp, "c", "x"), group[base]
        del group[base]
    assert_found("c/x/copy.blend saved again", cache)
    # Appended into a file in another folder: the objects bring their records along.
    bpy.ops.wm.read_homefile(use_empty=True)
    os.makedirs(os.path.join(tmp, "d"))
    bpy.ops.wm.save_as_mainfile(filepath=os.path.join(tmp, "d", "host.blend"))
    with bpy.data.libraries.load(os.path.join(tmp, "a", "project.blend")) as (src, dst):
        dst.objects = [n for n in src.objects if n.startswith(("Domain", "Glass", "HBK_"))]
    for obj in dst.objects:
        bpy.context.scene.collection.objects.link(obj)
    assert_found("appended into d/host.blend", cache)
    # Baked again there, with its voxel texture from a (the bake goes beside host.blend).
    assert bpy.ops.hydrobake.bake(effect="fluid", object_name="Domain") == {"FINISHED"}
    assert bpy.data.objects["Domain"].hydrobake_fluid.bake_folder.startswith(
        os.path.join(tmp, "d", "hydrobake_cache", "")), "re-baked"
    # Linked from the project moved whole (its records' base gone): relative to the library.
    os.rename(os.path.join(tmp, "a"), os.path.join(tmp, "moved"))
    bpy.ops.wm.read_homefile(use_empty=True)
    os.makedirs(os.path.join(tmp, "e"))
    bpy.ops.wm.save_as_mainfile(filepath=os.path.join(tmp, "e", "shot.blend"))
    with bpy.data.libraries.load(os.path.join(tmp, "moved", "project.blend"), link=True) as (
            src, dst):
        dst.objects = [n for n in src.objects if n.startswith(("Domain", "Glass", "HBK_"))]
    for obj in dst.objects:
        bpy.context.scene.collection.objects.link(obj)
    assert all(o.library is not None for o in dst.objects)
    surface = bpy.data.objects["HBK_Domain_surface"]
    held = len(surface.data.vertices)  # the frame the library saved: not rebuilt (crashed)
    assert_found("linked from the moved project", os.path.join(tmp, "moved", "hydrobake_cache",
                                                               ""))
    assert len(surface.data.vertices) == held and "hydrobake_frame" in surface
    print("SAVED ELSEWHERE OK")
