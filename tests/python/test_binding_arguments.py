"""Bad arguments to the binding raise InvalidArgument naming the argument and what it takes
("wind: must have 2 numbers, got 3"), before numpy or ctypes see them: IndexError, KeyError,
ctypes.ArgumentError and bare float()/int() messages came out before, some bad values were
taken silently (a short vector padded with zeros, an unknown obstacle kind taken as a box, a
float index truncated, an int64 index wrapped into int32). And what worked stays the same:
numpy scalars, tuples, lists and arrays give the bytes Python numbers give."""
import math

import numpy as np
import pytest

from hydrobake.core import _lib, arrays, caustics, errors, exr, fluid, image, rain, snow, water

F32 = np.float32
RAIN = {"width": 32, "height": 32, "map_width": 64, "map_height": 64, "cell_size": 0.003}
FLUID = {"resolution": (8, 8, 8), "box_max": (0.4, 0.4, 0.4), "max_particles": 1000,
         "textures": 2}
SNOW = {"flake_count": 100, "texture_width": 16, "texture_height": 16, "seed": 3}
WATER = {"width": 8, "height": 8}
CAUSTICS = {"auto_extent": 0, "extent": (0.0, 0.0, 0.8, 0.8)}
POS = np.array([[-1, -1, .5], [1, -1, .5], [1, 1, .5], [-1, 1, .5]], F32)
UV = np.array([[[0, 0], [1, 0], [1, 1]]], F32)
WH, GH = np.full((8, 8), 0.3, F32), np.zeros((8, 8), F32)
TEX, CMAP = np.ones((8, 8, 3), F32), np.ones((8, 8, 4), F32)
HEIGHT = np.zeros((8, 8), F32)


@pytest.fixture(scope="module")
def o():
    """One small handle per kernel: every call below is refused before it reaches one."""
    with rain.Rain(RAIN) as r, fluid.Fluid(FLUID) as f, snow.Snow(SNOW) as s, \
            water.Water(WATER) as w:
        yield {"rain": r, "fluid": f, "snow": s, "water": w}


def view_image(**kw):
    a = dict(water_height=WH, ground_height=GH, cell_size=0.1, camera=(0.4, 0.4, 5.0),
             ground_texture=TEX, caustic_map=CMAP, environment=None, params=CAUSTICS)
    a.update(kw)
    return caustics.view_image(**a)


def write_exr(tmp, **kw):
    a = dict(path=tmp / "x.exr", channels={"Y": HEIGHT})
    a.update(kw)
    return exr.write(**a)


NUMBER = "must be a number"
INTEGER = "must be an integer"
# (id, call on the handles (and a tmp folder), message the error must start with)
BAD = [
    # repro_1: refraction read normals' shape before checking it
    ("refraction-normals-1d", lambda o, t: rain.refraction(np.zeros(12, F32), HEIGHT),
     "normals: must have shape (height, width[, channels])"),
    ("refraction-normals-scalar", lambda o, t: rain.refraction(3.0, HEIGHT),
     "normals: must have shape (height, width[, channels])"),
    ("refraction-strength", lambda o, t: rain.refraction(np.zeros((8, 8, 3), F32), HEIGHT, "x"),
     f"strength: {NUMBER}"),
    # repro_2: fixed-length vectors, exactly N numbers
    ("set_car-wind-3", lambda o, t: o["rain"].set_car(10.0, 0.0, (1.0, 2.0, 3.0)),
     "wind: must have 2 numbers, got 3"),
    ("set_car-wind-1", lambda o, t: o["rain"].set_car(10.0, 0.0, (1.0,)),
     "wind: must have 2 numbers, got 1"),
    ("set_car-wind-scalar", lambda o, t: o["rain"].set_car(10.0, 0.0, 3.0),
     "wind: must be a sequence of 2 numbers"),
    ("set_car-wind-item", lambda o, t: o["rain"].set_car(10.0, 0.0, ("a", 1.0)),
     f"wind[0]: {NUMBER}"),
    ("fill_box-lo-4", lambda o, t: o["fluid"].fill_box((0, 0, 0, 0), (0.2, 0.2, 0.2)),
     "lo: must have 3 numbers, got 4"),
    ("fill_box-lo-2", lambda o, t: o["fluid"].fill_box((0.1, 0.1), (0.2, 0.2, 0.2)),
     "lo: must have 3 numbers, got 2"),
    ("fill_box-hi-4", lambda o, t: o["fluid"].fill_box((0, 0, 0), (0.2,) * 4),
     "hi: must have 3 numbers, got 4"),
    ("set_feature_rule-lo-7", lambda o, t: o["fluid"].set_feature_rule(0, [0] * 7, [1] * 6),
     "lo: must have 6 numbers, got 7"),
    ("set_feature_rule-lo-5", lambda o, t: o["fluid"].set_feature_rule(0, [.5] * 5, [1] * 6),
     "lo: must have 6 numbers, got 5"),
    ("set_feature_rule-hi-none", lambda o, t: o["fluid"].set_feature_rule(0, [0] * 6, None),
     "hi: must be a sequence of 6 numbers"),
    ("paint_sphere-center-4", lambda o, t: o["fluid"].paint_sphere(0, (.1, .1, .1, .1), .05),
     "center: must have 3 numbers, got 4"),
    ("paint_sphere-center-2", lambda o, t: o["fluid"].paint_sphere(0, (.1, .1), .05),
     "center: must have 3 numbers, got 2"),
    ("obstacle-centre-2", lambda o, t: o["fluid"].set_obstacles([("sphere", (.2, .2), .1)]),
     "obstacles[0].centre: must have 3 numbers, got 2"),
    ("obstacle-half_sizes-2",
     lambda o, t: o["fluid"].set_obstacles([("box", (.2, .2, .2), (.1, .1))]),
     "obstacles[0].half_sizes: must have 3 numbers, got 2"),
    ("obstacle-radius", lambda o, t: o["fluid"].set_obstacles([("sphere", (.2, .2, .2), "r")]),
     f"obstacles[0].radius: {NUMBER}"),
    ("view-camera-2", lambda o, t: caustics.view(WH, GH, 0.1, (0.4, 0.4), CAUSTICS),
     "camera: must have 3 numbers, got 2"),
    ("normal_map-texel_size-1", lambda o, t: image.normal_map(HEIGHT, (1.0,)),
     "texel_size: must have 2 numbers, got 1"),
    # repro_3: fluid.volume(unknown name)
    ("volume-nope", lambda o, t: o["fluid"].volume("nope"),
     "name: must be one of uvw_a, uvw_b, blend, motion, density, surface, features"),
    ("volume-none", lambda o, t: o["fluid"].volume(None), "name: must be one of uvw_a, "),
    ("volume-list", lambda o, t: o["fluid"].volume(["density"]), "name: must be one of uvw_a, "),
    # repro_4: scalars ctypes refused unnamed; noise3d's size before numpy allocates
    ("noise3d-persistence", lambda o, t: fluid.noise3d(4, 2, 1, [0.5]),
     f"persistence: {NUMBER}"),
    ("noise3d-size-negative", lambda o, t: fluid.noise3d(-1),
     "size: must be an integer in [1, 1024], got -1"),
    ("noise3d-size-too-big", lambda o, t: fluid.noise3d(2000),
     "size: must be an integer in [1, 1024], got 2000"),
    ("noise3d-size-fraction", lambda o, t: fluid.noise3d(2.5), f"size: {INTEGER}"),
    ("noise3d-period", lambda o, t: fluid.noise3d(4, "2"), f"period: {INTEGER}"),
    ("noise3d-octaves", lambda o, t: fluid.noise3d(4, 2, 1.5), f"octaves: {INTEGER}"),
    ("noise3d-seed", lambda o, t: fluid.noise3d(4, seed=-1), "seed: must be an integer in [0, "),
    ("normal_map-strength", lambda o, t: image.normal_map(HEIGHT, (1, 1), "x"),
     f"strength: {NUMBER}"),
    # repro_5: normal_map's height read before it was checked
    ("normal_map-height-float", lambda o, t: image.normal_map(3.0),
     "height: must be a numpy array, got float"),
    ("normal_map-height-list", lambda o, t: image.normal_map([[0.0, 1.0], [1.0, 0.0]]),
     "height: must be a numpy array, got list"),
    ("normal_map-height-none", lambda o, t: image.normal_map(None),
     "height: must be a numpy array"),
    ("normal_map-edge", lambda o, t: image.normal_map(HEIGHT, edge="X"),
     "edge: must be one of CLAMP, WRAP, MIRROR, got 'X'"),
    ("normal_map-encode", lambda o, t: image.normal_map(HEIGHT, encode="yes"),
     "encode: must be True or False"),
    # repro_6: lit_ground's edge; view_image's environment and texture shapes
    ("lit_ground-edge-X", lambda o, t: caustics.lit_ground(TEX, CMAP, "X"),
     "edge: must be one of CLAMP, WRAP, MIRROR, got 'X'"),
    ("lit_ground-edge-none", lambda o, t: caustics.lit_ground(TEX, CMAP, None),
     "edge: must be one of CLAMP, WRAP, MIRROR, got None"),
    ("view_image-environment-empty",
     lambda o, t: view_image(environment=np.zeros((0, 8, 3), F32)),
     "environment: must have shape (height, width[, 1|3|4]), at least 1 x 1"),
    ("view_image-environment-1d", lambda o, t: view_image(environment=np.ones(24, F32)),
     "environment: must have shape (height, width[, 1|3|4])"),
    ("view_image-environment-2ch",
     lambda o, t: view_image(environment=np.ones((4, 8, 2), F32)),
     "environment: must have shape (height, width[, 1|3|4])"),
    ("view_image-texture-1d", lambda o, t: view_image(ground_texture=np.ones(192, F32)),
     "ground_texture: must have shape (height, width[, 3|4])"),
    ("view_image-heading", lambda o, t: view_image(heading="north"), f"heading: {NUMBER}"),
    # repro_7: caustics.render's size before numpy allocates the map
    ("render-size-2**31", lambda o, t: caustics.render(WH, GH, 0.1, (2**31, 1), CAUSTICS),
     "size[0]: must be an integer in [1, 65536], got 2147483648"),
    ("render-size-negative", lambda o, t: caustics.render(WH, GH, 0.1, (-1, 4)),
     "size[0]: must be an integer in [1, 65536], got -1"),
    ("render-size-1", lambda o, t: caustics.render(WH, GH, 0.1, (4,)),
     "size: must have 2 integers, got 1"),
    ("render-size-fraction", lambda o, t: caustics.render(WH, GH, 0.1, (4, 4.5)),
     f"size[1]: {INTEGER}"),
    ("render-cell_size", lambda o, t: caustics.render(WH, GH, None, (4, 4)),
     f"cell_size: {NUMBER}"),
    ("render-workspace", lambda o, t: caustics.render(WH, GH, 0.1, (4, 4), workspace=3),
     "workspace: must be a caustics.Workspace or None"),
    ("view-channels", lambda o, t: caustics.view(WH, GH, 0.1, (0.4, 0.4, 5.0), channels=-1),
     "channels: must be an integer in [2, 4], got -1"),
    # repro_8: set_mesh's indices converted without a check
    ("set_mesh-triangles-wrap",
     lambda o, t: o["snow"].set_mesh(POS, np.array([[0, 1, 2**32 + 2]], np.int64), UV),
     "triangles: must be integers in [-2147483648, 2147483647], got 4294967298"),
    ("set_mesh-material_index-wrap",
     lambda o, t: o["snow"].set_mesh(POS, [[0, 1, 2]], UV, np.array([2**32], np.int64)),
     "material_index: must be integers in [-2147483648, 2147483647], got 4294967296"),
    ("set_mesh-triangles-float",
     lambda o, t: o["snow"].set_mesh(POS, np.array([[0, 1.9, 2.7]]), UV),
     "triangles: must be an array of integers, got dtype float64"),
    ("set_mesh-triangles-bool",
     lambda o, t: o["snow"].set_mesh(POS, np.ones((1, 3), bool), UV),
     "triangles: must be an array of integers, got dtype bool"),
    ("set_mesh-triangles-python-big",
     lambda o, t: o["snow"].set_mesh(POS, [[0, 1, 2**70]], UV),
     "triangles: must be integers in [-2147483648, 2147483647]"),
    ("set_mesh-material_index-float",
     lambda o, t: o["snow"].set_mesh(POS, [[0, 1, 2]], UV, [0.5]),
     "material_index: must be an array of integers, got dtype float64"),
    ("set_mesh-triangles-4", lambda o, t: o["snow"].set_mesh(POS, [0, 1, 2, 3], UV[:1]),
     "triangles: must be an array of integers of shape (n, 3), got shape (4,)"),
    ("set_mesh-positions-scalar", lambda o, t: o["snow"].set_mesh(3.0, [[0, 0, 0]], UV),
     "positions: must be an array of numbers of shape (n, 3)"),
    ("set_mesh-positions-text", lambda o, t: o["snow"].set_mesh(["abc"], [[0, 0, 0]], UV),
     "positions: must be an array of numbers"),
    ("set_mesh-uvs-none-text", lambda o, t: o["snow"].set_mesh(POS, [[0, 1, 2]], "uv"),
     "uvs: must be an array of numbers"),
    # repro_14: bare float() / int() / len() / unpacking, and silent coercions
    ("add_drop-x", lambda o, t: o["rain"].add_drop("x", 0.05, 10), f"x: {NUMBER}, got 'x'"),
    ("add_drop-mass", lambda o, t: o["rain"].add_drop(0.05, 0.05, None),
     f"mass: {NUMBER}, got None"),
    ("rain-step-none", lambda o, t: o["rain"].step(None), f"dt: {NUMBER}, got None"),
    ("rain-step-progress", lambda o, t: o["rain"].step(0.01, 3),
     "progress: must be a Progress or None"),
    ("set_car-speed", lambda o, t: o["rain"].set_car("fast", 0.0), f"speed: {NUMBER}"),
    ("set_car-accel-bool", lambda o, t: o["rain"].set_car(10.0, True), f"accel: {NUMBER}"),
    ("set_wiper_angles-scalar", lambda o, t: o["rain"].set_wiper_angles(3.0),
     "values: must be a sequence of numbers, got 3.0"),
    ("set_wiper_angles-item", lambda o, t: o["rain"].set_wiper_angles([10.0, "x"]),
     f"values[1]: {NUMBER}"),
    ("set_tangents-text", lambda o, t: o["rain"].set_tangents(["abc"]),
     "gravity_dir: must be an array of numbers"),
    ("rain-kernel", lambda o, t: rain.kernel("x"), f"q: {NUMBER}"),
    ("rain-compress", lambda o, t: rain.compress([1.0]), f"v: {NUMBER}"),
    ("rain-compress-params", lambda o, t: rain.compress(0.4, 5),
     "params: must be a Rain's params"),
    ("snow-step-nan", lambda o, t: o["snow"].step(float("nan")), f"substeps: {INTEGER}, got nan"),
    ("snow-step-fraction", lambda o, t: o["snow"].step(1.5), f"substeps: {INTEGER}, got 1.5"),
    ("snow-step-bool", lambda o, t: o["snow"].step(True), f"substeps: {INTEGER}, got True"),
    ("snow-step-text", lambda o, t: o["snow"].step("2"), f"substeps: {INTEGER}"),
    ("snow-step-too-big", lambda o, t: o["snow"].step(2**32),
     "substeps: must be an integer in [-2147483648, 2147483647]"),
    ("set_materials-string", lambda o, t: o["snow"].set_materials(["abc"]),
     "materials[0]: must be a sequence of 3 values (catch_chance, melts, sheds), got 'abc'"),
    ("set_materials-short", lambda o, t: o["snow"].set_materials([(0.1, False)]),
     "materials[0]: must have 3 values (catch_chance, melts, sheds), got 2"),
    ("set_materials-none", lambda o, t: o["snow"].set_materials(None),
     "materials: must be a sequence of materials"),
    ("set_materials-catch", lambda o, t: o["snow"].set_materials([("x", False, False)]),
     f"materials[0].catch_chance: {NUMBER}"),
    ("set_materials-melts", lambda o, t: o["snow"].set_materials([(0.1, "yes", False)]),
     "materials[0].melts: must be True or False"),
    ("snow-stamp_alpha", lambda o, t: snow.stamp_alpha("x", 0.5), f"temp_c: {NUMBER}"),
    ("snow-hit_chance", lambda o, t: snow.hit_chance(0.0, "x"), f"catch_chance: {NUMBER}"),
    ("snow-water_content-params", lambda o, t: snow.water_content(0.0, 5),
     "params: must be a Snow's params"),
    ("set_obstacles-cone",
     lambda o, t: o["fluid"].set_obstacles([("cone", (.2, .2, .2), (.1, .1, .1))]),
     "obstacles[0].kind: must be one of sphere, box, turned_box, mesh, got 'cone'"),
    ("set_obstacles-turned-short",
     lambda o, t: o["fluid"].set_obstacles([("turned_box", (.2, .2, .2), (.1, .1, .1))]),
     "obstacles[0]: must have 4 values (kind, centre, half_sizes, rotation), got 3"),
    ("set_obstacles-turned-rotation",
     lambda o, t: o["fluid"].set_obstacles([("turned_box", (.2,) * 3, (.1,) * 3, (1, 0, 0))]),
     "obstacles[0].rotation: must have 4 numbers, got 3"),
    ("set_obstacles-turned-unit",
     lambda o, t: o["fluid"].set_obstacles([("turned_box", (.2,) * 3, (.1,) * 3, (2, 0, 0, 0))]),
     "obstacles[0].rotation: length 2, must be a unit quaternion (w, x, y, z), length 1 +- 1e-3"),
    ("set_obstacles-mesh-short",
     lambda o, t: o["fluid"].set_obstacles([("mesh", (.2,) * 3, (.1,) * 3, (1, 0, 0, 0))]),
     "obstacles[0]: must have 5 values (kind, centre, half_sizes, rotation, field), got 4"),
    ("set_obstacles-mesh-field-shape",
     lambda o, t: o["fluid"].set_obstacles([("mesh", (.2,) * 3, (.1,) * 3, (1, 0, 0, 0),
                                             np.zeros((4, 4), F32))]),
     "obstacles[0].field: shape (4, 4): must be (nz, ny, nx), each in [2, 128]"),
    ("set_obstacles-mesh-field-side",
     lambda o, t: o["fluid"].set_obstacles([("mesh", (.2,) * 3, (.1,) * 3, (1, 0, 0, 0),
                                             np.zeros((4, 1, 4), F32))]),
     "obstacles[0].field: shape (4, 1, 4): must be (nz, ny, nx), each in [2, 128]"),
    ("set_obstacles-mesh-field-nan",
     lambda o, t: o["fluid"].set_obstacles([("mesh", (.2,) * 3, (.1,) * 3, (1, 0, 0, 0),
                                             np.where(np.arange(27).reshape(3, 3, 3) == 5,
                                                      np.nan, 1.0))]),
     "obstacles[0].field[0, 1, 2] = nan: must be a finite distance in [-1e6, 1e6] m"),
    ("set_obstacles-mesh-extent",
     lambda o, t: o["fluid"].set_obstacles([("mesh", (.2,) * 3, (.1, 0, .1), (1, 0, 0, 0),
                                             np.zeros((2, 2, 2), F32))]),
     "obs[0].extent[1] = 0: must be in (0, 1e6] m for a mesh"),
    ("set_obstacles-empty", lambda o, t: o["fluid"].set_obstacles([()]),
     "obstacles[0].kind: must be one of sphere, box, turned_box, mesh, got None"),
    ("set_obstacles-short", lambda o, t: o["fluid"].set_obstacles([("box", (.2, .2, .2))]),
     "obstacles[0]: must have 3 values (kind, centre, size), got 2"),
    ("set_obstacles-none", lambda o, t: o["fluid"].set_obstacles(None),
     "obstacles: must be a sequence of obstacles"),
    ("paint_sphere-texture-fraction", lambda o, t: o["fluid"].paint_sphere(1.5, (.2,) * 3, .05),
     f"texture: {INTEGER}, got 1.5"),
    ("paint_sphere-texture-nan",
     lambda o, t: o["fluid"].paint_sphere(float("nan"), (.2,) * 3, .05),
     f"texture: {INTEGER}, got nan"),
    ("paint_sphere-texture-bool", lambda o, t: o["fluid"].paint_sphere(True, (.2,) * 3, .05),
     f"texture: {INTEGER}, got True"),
    ("paint_sphere-texture-wraps", lambda o, t: o["fluid"].paint_sphere(2**32, (.2,) * 3, .05),
     "texture: must be an integer in [-2147483648, 2147483647], got 4294967296"),
    ("paint_sphere-radius", lambda o, t: o["fluid"].paint_sphere(0, (.2,) * 3, "big"),
     f"radius: {NUMBER}"),
    ("paint_mask-texture", lambda o, t: o["fluid"].paint_mask("0", np.zeros(729, F32)),
     f"texture: {INTEGER}"),
    ("paint_mask-mask", lambda o, t: o["fluid"].paint_mask(0, ["abc"]),
     "mask: must be an array of numbers"),
    ("paint_points-texture", lambda o, t: o["fluid"].paint_points(None, np.zeros((1, 3))),
     f"texture: {INTEGER}, got None"),
    ("paint_points-positions", lambda o, t: o["fluid"].paint_points(0, np.zeros(4)),
     "positions: must be an array of numbers of shape (n, 3), got shape (4,)"),
    ("paint_points-falloff",
     lambda o, t: o["fluid"].paint_points(0, np.zeros((1, 3)), falloff=[1]),
     f"falloff: {NUMBER}"),
    ("capture_feature_rule-texture",
     lambda o, t: o["fluid"].capture_feature_rule(0.5, np.zeros(729, F32)), f"texture: {INTEGER}"),
    ("set_feature_rule-texture",
     lambda o, t: o["fluid"].set_feature_rule(None, [0] * 6, [1] * 6), f"texture: {INTEGER}"),
    ("set_particles-pos", lambda o, t: o["fluid"].set_particles(np.zeros(4, F32)),
     "pos: must be an array of numbers of shape (n, 3), got shape (4,)"),
    ("set_particles-text", lambda o, t: o["fluid"].set_particles("abc"),
     "pos: must be an array of numbers, got 'abc'"),
    ("set_velocity_grid-text", lambda o, t: o["fluid"].set_velocity_grid(["a", "b"]),
     "velocity: must be an array of numbers"),
    ("fill_box-jitter", lambda o, t: o["fluid"].fill_box((0,) * 3, (.2,) * 3, "x"),
     f"jitter: {NUMBER}"),
    ("fluid-step-progress", lambda o, t: o["fluid"].step("p"),
     "progress: must be a Progress or None"),
    ("water-set_level", lambda o, t: o["water"].set_level("x"), f"level: {NUMBER}"),
    ("water-set_ground", lambda o, t: o["water"].set_ground([["abc"]]),
     "ground: must be an array of numbers"),
    ("load_state-none", lambda o, t: o["water"].load_state(None),
     "data: must be a bytes-like checkpoint"),
    ("load_state-text", lambda o, t: o["rain"].load_state("state"),
     "data: must be a bytes-like checkpoint"),
    ("uv_overlap-resolution", lambda o, t: image.uv_overlap(UV, 2.5), f"resolution: {INTEGER}"),
    ("uv_overlap-uvs", lambda o, t: image.uv_overlap("uv"), "uvs: must be an array of numbers"),
    ("grid_to_xyz-threads", lambda o, t: arrays.grid_to_xyz(np.zeros((2, 2, 2), F32), "x"),
     f"threads: {INTEGER}"),
    ("lit_ground-texture", lambda o, t: caustics.lit_ground([["abc"]], CMAP),
     "texture: must be an array of numbers"),
    # exr: half=None failed with "argument of type 'NoneType' is not iterable"
    ("exr-half-number", lambda o, t: write_exr(t, half=3),
     "half: must be a sequence of channel names, got 3"),
    ("exr-path", lambda o, t: write_exr(t, path=3), "path: must be a str, bytes or os.PathLike"),
    ("exr-path-nul", lambda o, t: write_exr(t, path=str(t / "a\0b.exr")),
     "path: must not contain a NUL character"),
    ("exr-channels-list", lambda o, t: write_exr(t, channels=[HEIGHT]),
     "channels: must be a dict of name -> (height, width) array, got list"),
    ("exr-channel-name", lambda o, t: write_exr(t, channels={1: HEIGHT}),
     "channels: names must be strings, got 1"),
    ("exr-channel-text", lambda o, t: write_exr(t, channels={"Y": [["abc"]]}),
     "channels['Y']: must be an array of numbers"),
    ("exr-compression", lambda o, t: write_exr(t, compression=["ZIP"]),
     "compression: must be one of NONE, ZIP, ZIPS"),
    ("exr-write_rgba", lambda o, t: exr.write_rgba(t / "x.exr", HEIGHT),
     "rgba: must have shape (height, width, 3|4), got (8, 8)"),
]


@pytest.mark.parametrize("call, message", [b[1:] for b in BAD], ids=[b[0] for b in BAD])
def test_a_bad_argument_is_refused_by_name(o, tmp_path, call, message):
    with pytest.raises(errors.InvalidArgument) as info:
        call(o, tmp_path)
    assert str(info.value).startswith(message), str(info.value)


def test_a_refused_exr_leaves_no_file(tmp_path):
    with pytest.raises(errors.InvalidArgument):
        write_exr(tmp_path, half=3)
    assert list(tmp_path.iterdir()) == []


# --- what worked before gives the same bytes --------------------------------------------------

class Vector:
    """A sequence that is neither a tuple, a list nor an array (as mathutils.Vector is)."""

    def __init__(self, *v):
        self.v = v

    def __len__(self):
        return len(self.v)

    def __getitem__(self, i):
        return self.v[i]


def state_after(cls, params, *calls):
    with cls(params) as h:
        for name, a in calls:
            getattr(h, name)(*a)
        return bytes(h.save_state())


@pytest.mark.parametrize("speed, accel, wind", [
    (np.float32(10.0), np.float32(1.5), (1.0, -2.0)),
    (np.float64(10.0), np.int64(1.5 * 2) / 2, [1.0, -2.0]),
    (10, 1.5, np.array([1.0, -2.0], np.float32)),
    (np.int32(10), 1.5, np.array([1, -2], np.int64)),
    (np.array(10.0), 1.5, Vector(np.float32(1.0), -2)),
    (10.0, 1.5, (np.float32(1.0), np.float64(-2.0))),
], ids=["f32-tuple", "f64-list", "int-array32", "i32-int-array", "0d-vector", "mixed-scalars"])
def test_set_car_takes_numbers_of_any_kind(speed, accel, wind):
    want = state_after(rain.Rain, RAIN, ("set_car", (10.0, 1.5, (1.0, -2.0))))
    assert state_after(rain.Rain, RAIN, ("set_car", (speed, accel, wind))) == want
    assert state_after(rain.Rain, RAIN, ("set_car", (10.0, 1.5, None))) != want  # wind counts


def test_rain_calls_take_numpy_scalars():
    plain = [("set_wiper_angles", ([],)), ("add_drop", (0.04, 0.05, 60.0)), ("step", (0.02,))]
    numpy = [("set_wiper_angles", (np.zeros(0, F32),)),
             ("add_drop", (np.float32(0.04), np.float64(0.05), np.int64(60))),
             ("step", (np.float32(0.02),))]
    assert state_after(rain.Rain, RAIN, *numpy) == state_after(rain.Rain, RAIN, *plain)
    assert rain.kernel(np.float32(0.5)) == rain.kernel(0.5)
    assert rain.compress(np.float64(1.0)) == rain.compress(1)


def test_fluid_calls_take_numpy_scalars_and_sequences():
    lo, hi = [-math.inf] * 6, [math.inf] * 6  # the rules' "any value" bounds pass unchanged
    lo[2] = 0.5
    plain = [("fill_box", ((0.0, 0.0, 0.0), (0.2, 0.2, 0.2), 0.0)),
             ("set_obstacles", ([("sphere", (0.3, 0.3, 0.3), 0.05),
                                 ("box", (0.1, 0.3, 0.1), (0.05, 0.05, 0.1))],)),
             ("paint_sphere", (1, (0.1, 0.1, 0.1), 0.05, 0.01)),
             ("set_feature_rule", (0, lo, hi))]
    numpy = [("fill_box", (np.zeros(3), [0.2, 0.2, np.float32(0.2)], np.int64(0))),
             ("set_obstacles", ([("sphere", np.full(3, 0.3), np.float32(0.05)),
                                 ("box", Vector(0.1, 0.3, 0.1), np.array([.05, .05, .1]))],)),
             ("paint_sphere", (np.int64(1), np.array([.1, .1, .1], F32), np.float32(0.05),
                               np.float64(0.01))),
             ("set_feature_rule", (np.int32(0), np.array(lo), tuple(hi)))]
    want = state_after(fluid.Fluid, FLUID, *plain)
    assert state_after(fluid.Fluid, FLUID, *numpy) == want
    # An integral float was taken as its integer before and still is.
    assert state_after(fluid.Fluid, FLUID, *plain[:2], ("paint_sphere", (1.0, (.1,) * 3, .05, .01)),
                       plain[3]) == want
    assert state_after(fluid.Fluid, FLUID, ("set_obstacles", ([],))) == \
        state_after(fluid.Fluid, FLUID)


def test_noise3d_takes_numpy_integers():
    want = fluid.noise3d(8, 2, 2, 0.5, 7)
    np.testing.assert_array_equal(
        fluid.noise3d(np.int64(8), np.int32(2), np.int16(2), np.float32(0.5), np.uint64(7)), want)
    assert fluid.noise3d(1, 1, 1).shape == (1, 1, 1)  # the bounds of size are taken
    with pytest.raises(errors.InvalidArgument, match=r"^period = 3: must be in \[1, size = 2\]"):
        fluid.noise3d(2, 3)  # the library's own checks still speak for the rest


def snow_run(triangles, material_index, materials, substeps):
    with snow.Snow(SNOW) as s:
        s.set_materials(materials)
        s.set_mesh(POS, triangles, np.concatenate([UV, UV]), material_index)
        s.step(substeps)
        return s.stats(), s.coverage()


def test_snow_calls_take_integer_arrays_and_numpy_scalars():
    tris = [[0, 1, 2], [0, 2, 3]]
    stats, cov = snow_run(tris, [0, 1], [(0.3, False, False), (0.1, True, False)], 3)
    for t, mi, mats, n in [
            (np.array(tris, np.int64), np.array([0, 1], np.uint8),
             [(np.float32(0.3), np.False_, 0), (0.1, np.True_, False)], np.int64(3)),
            (np.array(tris, np.int32), (0, 1), [[0.3, 0, 0], np.array([0.1, 1, 0])], 3.0),
            (np.array(tris, np.uint16).reshape(-1), np.array([0, 1]),
             ((0.3, False, False), (0.1, True, False)), np.int32(3))]:
        s2, c2 = snow_run(t, mi, mats, n)
        assert s2 == stats
        np.testing.assert_array_equal(c2, cov)
    # Out-of-range indices are still the library's to refuse, naming the index.
    with snow.Snow(SNOW) as s, pytest.raises(errors.InvalidArgument, match=r"^triangles\[2\] = 4"):
        s.set_mesh(POS, [[0, 1, 4]], UV)
    with snow.Snow(SNOW) as s, pytest.raises(errors.InvalidArgument, match=r"^triangles\[1\] = -1"):
        s.set_mesh(POS, [[0, -1, 2]], UV)


def test_image_and_caustics_calls_take_numpy_scalars_and_sequences():
    h = np.random.default_rng(2).random((8, 8)).astype(F32)
    want = image.normal_map(h, (0.1, 0.2), 1.5, encode=True)
    for ts, st, enc in [(np.array([0.1, 0.2]), np.float32(1.5), np.True_),
                        ([np.float64(0.1), 0.2], 1.5, 1),
                        (Vector(0.1, 0.2), np.int64(3) / 2, True)]:
        np.testing.assert_array_equal(image.normal_map(h, ts, st, encode=enc), want)
    m, _ = caustics.render(WH, GH, 0.1, (16, 8), CAUSTICS)
    assert m.shape == (8, 16, 4)
    for size in (np.array([16, 8]), [np.int32(16), np.int64(8)], Vector(16, 8)):
        np.testing.assert_array_equal(caustics.render(WH, GH, np.float32(0.1), size,
                                                      CAUSTICS)[0], m)
    uv, refl = caustics.view(WH, GH, 0.1, (0.4, 0.4, 5.0), CAUSTICS)
    uv2, refl2 = caustics.view(WH, GH, np.float64(0.1), np.array([0.4, 0.4, 5.0]), CAUSTICS,
                               np.int64(4))
    np.testing.assert_array_equal(uv2, uv)
    np.testing.assert_array_equal(refl2, refl)
    assert caustics.view(WH, GH, 0.1, (0.4, 0.4, 5.0), CAUSTICS, 2)[0].shape == (8, 8, 2)
    np.testing.assert_array_equal(caustics.lit_ground(TEX, CMAP, "MIRROR"),
                                  caustics.lit_ground(TEX.astype(np.float64), CMAP, "MIRROR"))


def test_view_image_takes_the_environments_it_took():
    env = np.random.default_rng(4).random((4, 8, 3)).astype(F32)
    want = view_image(environment=env, heading=0.5)
    np.testing.assert_array_equal(view_image(environment=env.astype(np.float64),
                                             heading=np.float32(0.5)), want)
    rgba = np.concatenate([env, np.ones((4, 8, 1), F32)], axis=2)
    np.testing.assert_array_equal(view_image(environment=rgba, heading=0.5), want)
    assert view_image(environment=env[..., :1]).shape == (8, 8, 3)  # one channel: grey sky
    assert view_image(ground_texture=TEX[..., 0]).shape == (8, 8, 3)  # grey ground


def test_a_2d_environment_is_grey_sky_as_one_channel_is():
    # It was broadcast against the view's rows (a wrong image on a square grid, an error on
    # another).
    grey = np.random.default_rng(4).random((4, 8, 1)).astype(F32)
    np.testing.assert_array_equal(view_image(environment=grey[..., 0]),
                                  view_image(environment=grey))


def test_an_integral_float_is_taken_as_its_integer():
    # As int() took it where the binding converted, and as the params take "whole numbers";
    # ctypes and numpy refused it elsewhere.
    np.testing.assert_array_equal(fluid.noise3d(4.0, 2, 2.0), fluid.noise3d(4, 2, 2))
    np.testing.assert_array_equal(caustics.render(WH, GH, 0.1, (16.0, 8), CAUSTICS)[0],
                                  caustics.render(WH, GH, 0.1, (16, 8), CAUSTICS)[0])
    assert caustics.view(WH, GH, 0.1, (0.4, 0.4, 5.0), CAUSTICS, 3.0)[0].shape == (8, 8, 3)


def test_refraction_keeps_the_background_shape():
    n = np.zeros((8, 8, 3), F32)
    n[..., 2] = 1
    assert rain.refraction(n, HEIGHT).shape == (8, 8)
    assert rain.refraction(n, np.ones((8, 8, 1), F32)).shape == (8, 8)
    assert rain.refraction(n, np.ones((4, 4, 3), F32), np.float32(0.1)).shape == (8, 8, 3)


def test_exr_half_none_means_no_half_channels(tmp_path):
    chans = {"R": HEIGHT + 0.1, "G": HEIGHT}
    for half, want in [(None, {"R": False, "G": False}), (False, {"R": False, "G": False}),
                       ((), {"R": False, "G": False}), (True, {"R": True, "G": True}),
                       (np.True_, {"R": True, "G": True}), (["R"], {"R": True, "G": False}),
                       ({"G"}, {"R": False, "G": True}), ("R", {"R": True, "G": False})]:
        p = tmp_path / "h.exr"
        exr.write(p, chans, half=half)
        with exr.Reader(p) as r:
            assert r.channels == want, half
    exr.write_rgba(tmp_path / "rgba.exr", np.ones((2, 2, 4)), half=True)
    assert exr.read(tmp_path / "rgba.exr")["A"].tolist() == [[1, 1], [1, 1]]


def test_a_progress_is_still_passed_through():
    prog = _lib.Progress()
    with water.Water(WATER) as w:
        w.set_level(np.float32(0.1))
        w.step(prog)
        w.step(None)
        prog.cancel = 1
        with pytest.raises(errors.Cancelled):
            w.step(prog)
