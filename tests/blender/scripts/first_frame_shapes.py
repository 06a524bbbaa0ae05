"""Every effect reads the scene's shapes from its bake's frames (the first, or for the snow's
mesh each), whatever frame the scene is on when Bake or Resume is pressed: a cube squashed by
an animated shape key (snow, by UV and in BOX mode), a floor that tilts under a pool that
slides (caustics), a glass that widens (rain) and a water column that moves (fluid) bake the
same bytes and wiring from frame 1 and from frame 9, and the scene is left on its frame. An
animated value changed on the first frame and not keyed is not read (the frames after it
would not have it). A snow bake extended by a Resume pressed on frame 9 equals the bake of
the whole range."""
import hashlib
import json
import os

import bpy
import numpy as np

import in_blender

in_blender.enable()
from hydrobake.core import vdb  # noqa: E402

tmp = in_blender.args()[0]
bpy.ops.wm.save_as_mainfile(filepath=os.path.join(tmp, "first_frame.blend"))
scene = bpy.context.scene


def morph(obj, name, move):
    """A shape key ``name`` moving each vertex by move(co), at 0 on frame 1 and 1 on 11."""
    if obj.data.shape_keys is None:
        obj.shape_key_add(name="Basis")
    key = obj.shape_key_add(name=name)
    for v in key.data:
        v.co = move(v.co.copy())
    key.value = 0.0
    key.keyframe_insert("value", frame=1)
    key.value = 1.0
    key.keyframe_insert("value", frame=11)


def slide(obj, x0, x1):
    obj.location.x = x0
    obj.keyframe_insert("location", frame=1)
    obj.location.x = x1
    obj.keyframe_insert("location", frame=11)


def content(folder, name, checksum):
    """A file's checksum; a .vdb's grids' values instead (OpenVDB writes a random UUID into
    every file)."""
    if not name.endswith(".vdb"):
        return checksum
    grids = vdb.read(os.path.join(folder, name))
    return hashlib.sha256(b"".join(
        n.encode() + vdb.read_grid(os.path.join(folder, name), n).tobytes()
        for n in sorted(grids))).hexdigest()


def frames_of(settings):
    """The bake's frames' contents, by frame (not the file names' tag), and its params."""
    with open(os.path.join(settings.bake_folder, "manifest.json")) as f:
        m = json.load(f)
    return {f: sorted(content(settings.bake_folder, n, c) for n, c in files.items())
            for f, files in m["frames"].items()}, m["params"]


def bake_on(current, effect, obj, settings, wiring=lambda: None, resume=False):
    """(frames, params, wiring) of a bake pressed with the scene on ``current``, freed after
    unless it is to be resumed."""
    scene.frame_set(current)
    assert bpy.ops.hydrobake.bake(effect=effect, object_name=obj.name,
                                  resume=resume) == {"FINISHED"}
    assert scene.frame_current == current, (effect, scene.frame_current)
    return (*frames_of(settings), wiring())


def free(effect, obj):
    assert bpy.ops.hydrobake.free_bake(effect=effect, object_name=obj.name) == {"FINISHED"}


def same_on_1_and_9(effect, obj, settings, wiring=lambda: None):
    on1 = bake_on(1, effect, obj, settings, wiring)
    free(effect, obj)
    on9 = bake_on(9, effect, obj, settings, wiring)
    free(effect, obj)
    differ = {(g, k): (v, on9[1][g].get(k)) for g in on1[1] for k, v in on1[1][g].items()
              if on9[1][g].get(k) != v}
    assert not differ, f"{effect}: params on frame 1 / frame 9: {differ}"
    assert on1[0] == on9[0], f"{effect}: the bake pressed on frame 9 differs"
    assert on1[2] == on9[2], f"{effect}: the wiring differs on frame 9: {on1[2]} / {on9[2]}"
    print(effect, "same on frames 1 and 9")
    return on1


# --- snow: a cube squashed to a fifth of its height by frame 11 -------------------------
cube = bpy.data.objects["Cube"]
morph(cube, "Squash", lambda co: (co.x, co.y, co.z * 0.2))
s = in_blender.snow(cube, (1, 3), 20, 32)
s.auto_volume = False  # (a volume fitted to a squashed cube would differ by itself)
same_on_1_and_9("snow", cube, s)
whole = bake_on(1, "snow", cube, s)[0]  # frames 1-3
free("snow", cube)
s.frame_end = 2
bake_on(1, "snow", cube, s)
s.frame_end = 3
resumed = bake_on(9, "snow", cube, s, resume=True)[0]  # the squash reads 0.8 here
assert resumed == whole, "a resume pressed on frame 9 differs from the bake of frames 1-3"
free("snow", cube)


def box_atlas():
    """The BOX atlas coordinates the bake's modifier gives the cube on frame 1."""
    keep = scene.frame_current
    scene.frame_set(1)
    ev = cube.evaluated_get(bpy.context.evaluated_depsgraph_get())
    mesh = ev.to_mesh()
    uv = np.empty(len(mesh.loops) * 3, np.float32)
    mesh.attributes["HBK_SnowBox"].data.foreach_get("vector", uv)
    ev.to_mesh_clear()
    scene.frame_set(keep)
    return uv.round(6).tolist()


s.snow.contact_mode = "BOX"
same_on_1_and_9("snow", cube, s, box_atlas)
s.enabled = False

# --- caustics: a pool sliding 0.5 m over a floor that tilts -------------------------------
pool = in_blender.new_plane("Pool")
pool.data.materials.append(bpy.data.materials.new("Water"))
slide(pool, 0.0, 0.5)
floor = in_blender.new_plane("Floor")
floor.scale, floor.location = (3.0, 3.0, 1.0), (0.0, 0.0, -0.5)
floor.data.materials.append(bpy.data.materials.new("Floor"))
morph(floor, "Tilt", lambda co: (co.x, co.y, co.z + 0.3 * co.x))
c = pool.hydrobake_caustics
c.enabled, c.ground_object = True, floor
c.use_scene_range, c.frame_start, c.frame_end = False, 1, 2
c.water.width, c.map_resolution = 32, 64


def floor_mapping():
    """Where the floor's material looks the maps up: the grid the bake wired."""
    return sorted((n.get("hydrobake"), [round(v, 6) for v in n.inputs["Location"].default_value])
                  for n in floor.data.materials[0].node_tree.nodes
                  if n.type == "MAPPING" and n.get("hydrobake"))


caustics = same_on_1_and_9("caustics", pool, c, floor_mapping)
assert caustics[2], "the floor was not wired"
c.enabled = False

# --- rain: a glass twice as wide by frame 11 (the grid follows its size) -------------------
glass = in_blender.uv_plane("Glass")
morph(glass, "Wide", lambda co: (co.x * 2.0, co.y, co.z))
r = in_blender.rain_once(glass)  # 5 cm cells
rain = same_on_1_and_9("rain", glass, r)
assert rain[1]["rain"]["width"] == 40, rain[1]["rain"]["width"]  # the 2 m glass of frame 1
scene.frame_set(1)
glass.data.shape_keys.key_blocks["Wide"].value = 1.0  # changed on frame 1 and not keyed
assert bpy.ops.hydrobake.bake(effect="rain", object_name="Glass") == {"FINISHED"}
assert frames_of(r) == rain[:2], "the bake read a value its animation does not have there"
free("rain", glass)
r.enabled = False

# --- fluid: a water column that slides along the domain -----------------------------------
domain, column, f = in_blender.dam_break((16, 8, 8), frames=(1, 2), substeps=2)
slide(column, 0.15, 0.6)
same_on_1_and_9("fluid", domain, f)
print("FIRST FRAME SHAPES OK")
