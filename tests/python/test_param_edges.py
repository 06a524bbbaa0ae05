"""Every parameter of every kernel's params table, at and beyond its range, through the binding.

Beyond the range (and NaN / infinity for floats) the call that takes the params must raise
InvalidArgument whose message names the parameter and the table's range in the library's own
format ("strength = -2: must be in [0, 1000] 1"), both through the binding (which validates
before calling C) and when the unvalidated struct goes straight to the C entry point. Exactly at
min and at max (the rest at small defaults) the handle is created and one small step or frame
runs, unless the library refuses the combination with another parameter, which is listed below
with the message it must give.

Arrays: out of range, one element at a time (the first and the last, so the message must name
the right index); at the edges, every element on its own (the others at the base values), since
a vector's elements usually mean different things (x, y, z; lower, upper)."""
import ctypes
import math
import os
import re

import numpy as np
import pytest

from hydrobake.core import _lib, caustics, errors, fluid, rain, snow, water
from hydrobake.core._lib import Message
from hydrobake.core.params import BOOL, ENUM, F32, I32, U64

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

SPECS = {"rain": rain.Rain.spec(), "snow": snow.Snow.spec(), "caustics": caustics.spec(),
         "water": water.Water.spec(), "fluid": fluid.Fluid.spec()}
HANDLES = {"rain": rain.Rain, "snow": snow.Snow, "water": water.Water, "fluid": fluid.Fluid}

# Small sizes so that one step is milliseconds; otherwise the library's defaults, plus what makes
# the step reach the code a parameter drives (a wiper on the rain glass, an explicit caustics
# extent, a snow volume that flakes cross within a few substeps).
BASE = {
    "rain": {"width": 32, "height": 32, "map_width": 64, "map_height": 64, "cell_size": 0.003,
             "rain_rate": 20000.0, "wiper_count": 1, "wiper_pivot": (0.048, -0.01, 0.07, -0.01),
             "blade_offset": 0.005, "blade_length": 0.08, "blade_width": 0.005,
             "wiper_period": 0.2, "wiper_phase": 0.1, "switch_margin": 0.01, "seed": 3,
             "threads": 2},
    "snow": {"flake_count": 400, "texture_width": 16, "texture_height": 16,
             "volume_min": (-1.0, -1.0, 0.4), "volume_max": (1.0, 1.0, 1.0), "threads": 2},
    "caustics": {"auto_extent": 0, "extent": (0.0, 0.0, 0.8, 0.8), "threads": 2},
    "water": {"width": 8, "height": 8, "threads": 2},
    "fluid": {"resolution": (8, 8, 8), "box_max": (0.4, 0.4, 0.4), "dt": 0.01, "substeps": 2,
              "max_particles": 1000, "threads": 2},
}
SNOW_SUBSTEPS = 4


def f32_up(x):
    """The least float32 >= x."""
    f = np.float32(x)
    return float(f) if float(f) >= x else float(np.nextafter(f, np.float32(np.inf)))


def f32_down(x):
    """The greatest float32 <= x."""
    f = np.float32(x)
    return float(f) if float(f) <= x else float(np.nextafter(f, np.float32(-np.inf)))


def stored(p, v):
    """v as the C struct holds it."""
    if p.type == F32:
        return float(np.float32(v))
    return int(v)


# --- beyond the range ---------------------------------------------------------------------------

def outside_values(p):
    """(label, value) pairs outside [min, max], for one element of p."""
    if p.type == F32:
        lo, hi = p.min, p.max
        # The library takes the bounds rounded to float32 (what a float caller stores for
        # them), so the first floats outside are the neighbours of the rounded bounds.
        out = [("below", lo - max(1.0, abs(lo)) * 0.01),
               ("below_f32", float(np.nextafter(np.float32(lo), np.float32(-np.inf)))),
               ("above", hi + max(1.0, abs(hi)) * 0.01),
               ("above_f32", float(np.nextafter(np.float32(hi), np.float32(np.inf)))),
               ("nan", math.nan), ("inf", math.inf), ("-inf", -math.inf)]
        return out
    if p.type in (I32, BOOL, ENUM):
        out = []
        if p.min > -2**31:
            out.append(("below", int(p.min) - 1))
        if p.max < 2**31 - 1:
            out.append(("above", int(p.max) + 1))
        return out
    assert p.type == U64
    # [0, 2^64]: both bounds are the type's own limits, nothing lies outside.
    assert p.min == 0 and p.max >= 2.0**64 - 1
    return []


def outside_cases():
    for effect, spec in SPECS.items():
        for p in spec.params:
            for k in sorted({0, p.count - 1}):
                for label, value in outside_values(p):
                    name = f"{p.name}[{k}]" if p.count > 1 else p.name
                    yield pytest.param(effect, p.name, k, value, id=f"{effect}.{name}-{label}")


def with_element(spec, name, k, value, base):
    p = spec.by_name[name]
    if p.count == 1:
        return value
    v = list(base.get(name, p.default))
    v[k] = value
    return tuple(v)


SMALL_WH = (0.02 * np.sin(np.arange(64, dtype=np.float32) * 0.7)).reshape(8, 8)
SMALL_GH = np.full((8, 8), -1.0, np.float32)


def through_binding(effect, values):
    """Makes the handle (or the caustics calls) from a dict, and frees it."""
    if effect == "caustics":
        caustics.render(SMALL_WH, SMALL_GH, 0.1, (8, 8), values)
        caustics.view(SMALL_WH, SMALL_GH, 0.1, (0.4, 0.4, 5.0), values)
    else:
        HANDLES[effect](values).close()


def raw_struct(effect, name, k, value):
    """The defaults with one field set, never checked by the binding."""
    spec = SPECS[effect]
    s = spec.struct()
    spec._default_fn(ctypes.byref(s))
    p = spec.by_name[name]
    if p.count > 1:
        getattr(s, name)[k] = value
    else:
        setattr(s, name, value)
    return s


def raw_calls(effect, s):
    """The C entry points that take the params, each given the struct as it is."""
    lib = _lib.lib
    if effect == "caustics":
        return [lambda: caustics.render(SMALL_WH, SMALL_GH, 0.1, (8, 8), s),
                lambda: caustics.view(SMALL_WH, SMALL_GH, 0.1, (0.4, 0.4, 5.0), s)]

    def create():
        h = ctypes.c_void_p()
        try:
            getattr(lib, f"hbk_{effect}_create")(ctypes.byref(h), ctypes.byref(s), Message())
        finally:
            if h.value:
                getattr(lib, f"hbk_{effect}_destroy")(h)
    return [create]


def assert_names_range(message, p, k, value):
    """`name[k] = v: must be [a finite number ]in [min, max] unit`, the range the table's."""
    name = re.escape(f"{p.name}[{k}]" if p.count > 1 else p.name)
    finite = "a finite number " if p.type == F32 and not math.isfinite(value) else ""
    m = re.fullmatch(rf"{name} = (\S+): must be {finite}in \[(\S+), (\S+)\] "
                     rf"{re.escape(p.unit)}", message)
    assert m, f"{message!r} does not name {p.name} and its range"
    got, lo, hi = m.groups()
    assert (lo, hi) == (f"{p.min:g}", f"{p.max:g}"), message
    assert float(lo) == pytest.approx(p.min, rel=1e-5) and \
        float(hi) == pytest.approx(p.max, rel=1e-5), message
    want = stored(p, value) if math.isfinite(value) else value
    if math.isnan(want):
        assert math.isnan(float(got)), message
    else:
        assert float(got) == pytest.approx(want, rel=1e-5, abs=1e-300), message


@pytest.mark.parametrize("effect, name, k, value", outside_cases())
def test_outside_the_range_is_refused_naming_the_parameter_and_range(effect, name, k, value):
    spec = SPECS[effect]
    p = spec.by_name[name]
    # The binding, from a dict.
    values = {name: with_element(spec, name, k, value, {})}
    with pytest.raises(errors.InvalidArgument) as exc:
        through_binding(effect, values)
    assert type(exc.value) is errors.InvalidArgument
    assert_names_range(str(exc.value), p, k, value)
    # The C library itself, from a struct the binding never checked.
    for call in raw_calls(effect, raw_struct(effect, name, k, value)):
        with pytest.raises(errors.InvalidArgument) as exc:
            call()
        assert type(exc.value) is errors.InvalidArgument
        assert_names_range(str(exc.value), p, k, value)


def enum_cases():
    for e, s in SPECS.items():
        for p in s.params:
            if p.type == ENUM:
                yield pytest.param(e, p.name, id=f"{e}.{p.name}")


@pytest.mark.parametrize("effect, name", enum_cases())
def test_enum_items_are_taken_by_name(effect, name):
    spec = SPECS[effect]
    p = spec.by_name[name]
    for i, item in enumerate(p.items):
        s = spec.to_struct({name: item if p.count == 1 else (item,) * p.count})
        assert (getattr(s, name) if p.count == 1 else tuple(getattr(s, name))) == \
            (i if p.count == 1 else (i,) * p.count)


@pytest.mark.parametrize("effect, name", enum_cases())
def test_an_unknown_enum_item_is_refused_naming_the_items(effect, name):
    p = SPECS[effect].by_name[name]
    bad = "NOT_AN_ITEM"
    value = bad if p.count == 1 else (bad,) + tuple(p.items[i] for i in p.default[1:])
    with pytest.raises(errors.InvalidArgument) as exc:
        through_binding(effect, {name: value})
    label = f"{name}[0]" if p.count > 1 else name
    assert str(exc.value).startswith(f"{label} = 'NOT_AN_ITEM': must be one of "), exc.value
    assert str(exc.value).endswith(", ".join(p.items)), exc.value


def test_every_kernel_with_a_params_table_is_covered():
    found = set()
    folder = os.path.join(ROOT, "c_core", "include")
    for fname in os.listdir(folder):
        if fname.endswith(".h"):
            with open(os.path.join(folder, fname)) as f:
                found |= set(re.findall(r"\bhbk_(\w+)_params_info\s*\(", f.read()))
    assert found == set(SPECS)
    for spec in SPECS.values():
        assert spec.params


# --- at the edges -------------------------------------------------------------------------------

def edge_value(p, side):
    """The value at an edge: min / max as the table has them (float32-rounded to nearest by the
    struct, as any caller's float would be), or min_f32 / max_f32, the float32 nearest inside."""
    if side == "min_f32":
        return f32_up(p.min)
    if side == "max_f32":
        return f32_down(p.max)
    bound = p.min if side == "min" else p.max
    if p.type == F32:
        return bound
    if p.type == U64:
        return min(int(bound), 2**64 - 1)  # the table says 2^64, the type stops one short
    return int(bound)


def edge_sides(p):
    sides = ["min", "max"]
    if p.type == F32:
        # Where the bound is not a float32, also the float32 on the inner side of it (the
        # rounded bound itself is "min" / "max", which the library must take too).
        if float(np.float32(p.min)) != p.min:
            sides.append("min_f32")
        if float(np.float32(p.max)) != p.max:
            sides.append("max_f32")
    return sides


# Other parameters an edge needs to be a valid combination, so that it runs. (effect, name or
# name[k], side) -> overrides; "min" / "max" also cover "min_f32" / "max_f32". An override of the
# parameter itself sets the other elements of its vector.
TINY = float(np.float32(1e-4))  # the table's least spacing and kernel radius, as float32
COMPANIONS = {
    # The map must be within 1/64 and 64 times the grid.
    ("rain", "width", "max"): {"map_width": 256},
    ("rain", "height", "max"): {"map_height": 256},
    ("rain", "map_width", "max"): {"width": 256},
    ("rain", "map_height", "max"): {"height": 256},
    # Particles and blades at most a quarter of the glass's short side.
    ("rain", "cell_size", "min"): {"particle_radius": 5e-4, "blade_width": f32_up(5e-4)},
    ("rain", "particle_radius", "max"): {"cell_size": 0.01},
    ("rain", "blade_width", "max"): {"cell_size": 0.03, "width": 80, "height": 80,
                                     "map_width": 160, "map_height": 160},
    # |gravity_dir| and |airflow_dir| at most 1: the other component 0.
    ("rain", "gravity_dir[0]", "min"): {"gravity_dir": (0.0, 0.0)},
    ("rain", "gravity_dir[0]", "max"): {"gravity_dir": (0.0, 0.0)},
    ("rain", "airflow_dir[0]", "min"): {"airflow_dir": (0.0, 0.0)},
    ("rain", "airflow_dir[0]", "max"): {"airflow_dir": (0.0, 0.0)},
    # Rain drops at most 256 cells wide.
    ("water", "cell_size", "min"): {"rain_radius": 0.01},
    ("water", "rain_radius", "max"): {"cell_size": 1.0},
    # The sun above the horizon; a point light for its position; periodic needs auto_extent.
    ("caustics", "light_direction[0]", "min"): {"light_direction": (0.0, 0.0, 1e6)},
    ("caustics", "light_direction[0]", "max"): {"light_direction": (0.0, 0.0, 1e6)},
    ("caustics", "light_direction[1]", "min"): {"light_direction": (0.0, 0.0, 1e6)},
    ("caustics", "light_direction[1]", "max"): {"light_direction": (0.0, 0.0, 1e6)},
    **{("caustics", f"light_position[{k}]", s): {"light_type": 1}
       for k in range(3) for s in ("min", "max")},
    ("caustics", "periodic", "max"): {"auto_extent": 1},
    # smoothing_length and metaball_radius within 1..4 particle_spacing; at most 4096 kernel
    # radii across the box; default_texture below textures.
    # A 1 cm box for the tiny kernels, since the SPH neighbour grid is dense, (box / h)^3 cells
    # (see test_the_sph_grid_the_checks_allow_fits_in_memory), and a 0.1 ms frame, since their
    # stable SPH step is microseconds.
    ("fluid", "particle_spacing", "min"): {"smoothing_length": 2e-4, "metaball_radius": 2e-4,
                                           "box_max": (0.01, 0.01, 0.01), "dt": 1e-4},
    ("fluid", "particle_spacing", "max"): {"smoothing_length": 20.0, "metaball_radius": 20.0},
    ("fluid", "smoothing_length", "min"): {"particle_spacing": TINY, "metaball_radius": 2e-4,
                                           "box_max": (0.01, 0.01, 0.01), "dt": 1e-4},
    ("fluid", "smoothing_length", "max"): {"particle_spacing": 10.0, "metaball_radius": 20.0},
    ("fluid", "metaball_radius", "min"): {"particle_spacing": TINY, "smoothing_length": 2e-4,
                                          "box_max": (0.01, 0.01, 0.01), "dt": 1e-4},
    ("fluid", "metaball_radius", "max"): {"particle_spacing": 10.0, "smoothing_length": 20.0},
    **{("fluid", f"{n}[{k}]", s): {"particle_spacing": 1.0, "smoothing_length": 4.0,
                                   "metaball_radius": 2.0}
       for n, s in (("box_min", "min"), ("box_max", "max")) for k in range(3)},
    ("fluid", "default_texture", "max"): {"textures": 8},
}

# Edges the library refuses whatever the others are (a vector's order, or its own other
# elements), with the message it must give. (effect, name or name[k], side) -> regex.
REFUSED = {
    # A box's max must exceed its min, element by element.
    **{("snow", f"volume_min[{k}]", "max"): rf"^volume_max\[{k}\] = .*: must be > volume_min\[{k}\]"
       for k in range(3)},
    **{("snow", f"volume_max[{k}]", "min"): rf"^volume_max\[{k}\] = .*: must be > volume_min\[{k}\]"
       for k in range(3)},
    **{("fluid", f"box_min[{k}]", "max"):
       rf"^box_max\[{k}\] = .*: must be greater than box_min\[{k}\]" for k in range(3)},
    **{("fluid", f"box_max[{k}]", "min"):
       rf"^box_max\[{k}\] = .*: must be greater than box_min\[{k}\]" for k in range(3)},
    # Curves whose points must ascend: the first at the range's max, the last at its min, or a
    # middle one beyond its neighbours.
    ("snow", "water_temperature[0]", "max"): r"^water_temperature\[1\] = 3: must be > "
                                             r"water_temperature\[0\] = 10",
    ("snow", "water_temperature[1]", "min"): r"^water_temperature\[1\] = -10: must be > ",
    ("snow", "tension_water[0]", "max"): r"^tension_water\[1\] = 15: must be > "
                                         r"tension_water\[0\] = 100",
    ("snow", "tension_water[1]", "min"): r"^tension_water\[1\] = 0: must be > ",
    ("snow", "tension_water[1]", "max"): r"^tension_water\[2\] = 25: must be > "
                                         r"tension_water\[1\] = 100",
    ("snow", "tension_water[2]", "min"): r"^tension_water\[2\] = 0: must be > ",
    ("snow", "sinter_temperature[0]", "max"): r"^sinter_temperature\[1\] = -2: must be > "
                                              r"sinter_temperature\[0\] = 10",
    ("snow", "sinter_temperature[1]", "min"): r"^sinter_temperature\[1\] = -20: must be > ",
    ("snow", "bleed_water[0]", "max"): r"^bleed_water\[1\] = 25: must be > "
                                       r"bleed_water\[0\] = 100",
    ("snow", "bleed_water[1]", "min"): r"^bleed_water\[1\] = 0: must be > ",
    # The sun below the horizon.
    ("caustics", "light_direction[2]", "min"): r"^light_direction = \(0, 0, -1e\+06\): must "
                                               r"point up",
    # A point light below the water.
    ("caustics", "light_position[2]", "min"): r"light_position",
    # The map's xmax must exceed its xmin, ymax its ymin.
    ("caustics", "extent[0]", "max"): r"^extent = \(1e\+06, 0, 0\.8, 0\.8\): xmax must be > xmin",
    ("caustics", "extent[1]", "max"): r"^extent = \(0, 1e\+06, 0\.8, 0\.8\): xmax must be > xmin",
    ("caustics", "extent[2]", "min"): r"^extent = \(0, 0, -1e\+06, 0\.8\): xmax must be > xmin",
    ("caustics", "extent[3]", "min"): r"^extent = \(0, 0, 0\.8, -1e\+06\): xmax must be > xmin",
}

# Edges whose step would take seconds or gigabytes: only the params are validated (the binding
# and the library's own check), no handle is made. (effect, name, side) -> why.
VALIDATE_ONLY = {
    ("snow", "flake_count", "max"): "20 million flakes: about a gigabyte and seconds to scatter",
}


def edge_cases():
    for effect, spec in SPECS.items():
        for p in spec.params:
            for k in range(p.count):
                label = f"{p.name}[{k}]" if p.count > 1 else p.name
                for side in edge_sides(p):
                    yield pytest.param(effect, p.name, k, side, id=f"{effect}.{label}-{side}")


def run_rain(values):
    with rain.Rain(values) as r:
        p = r.params
        gw, gh = p.width * p.cell_size, p.height * p.cell_size
        r.add_drop(0.5 * gw, 0.7 * gh, 60.0)  # heavy enough to run, trail and merge
        r.step(1 / 24)
        for out in (r.heightmap(), r.wetness()):
            assert out.shape == r.map_shape and np.isfinite(out).all()
        w = r.water()
        assert w["rain_in"] == pytest.approx(w["on_glass"] + w["wiped"] + w["run_off"],
                                             rel=1e-9, abs=1e-9)


def snow_mesh():
    """A 2 x 2 m quad at z = 0.5, across the base volume."""
    pos = np.array([[-1, -1, 0.5], [1, -1, 0.5], [1, 1, 0.5], [-1, 1, 0.5]], np.float32)
    tris = np.array([[0, 1, 2], [0, 2, 3]], np.int32)
    uvs = np.array([[[0, 0], [1, 0], [1, 1]], [[0, 0], [1, 1], [0, 1]]], np.float32)
    return pos, tris, uvs


def run_snow(values):
    with snow.Snow(values) as s:
        s.set_mesh(*snow_mesh())
        s.step(SNOW_SUBSTEPS)
        for out in (s.coverage(), s.depth()):
            assert np.isfinite(out).all()
        assert np.isfinite(s.flakes()).all()
        assert s.stats()["substeps"] == SNOW_SUBSTEPS


def run_water(values):
    with water.Water(values) as w:
        h, wd = w.shape
        y, x = np.mgrid[0:h, 0:wd]
        bump = np.exp(-((x - wd / 2) ** 2 + (y - h / 2) ** 2) / 4.0)
        w.set_surface((0.1 + 0.02 * bump).astype(np.float32))
        w.step()
        for out in (w.surface(), w.depth(), w.velocity()):
            assert np.isfinite(out).all()
        assert w.step_count() == w.params.substeps  # solver steps, `substeps` a frame


def run_caustics(values):
    m, stats = caustics.render(SMALL_WH, SMALL_GH, 0.1, (16, 16), values)
    assert np.isfinite(m).all() and m.shape == (16, 16, 4)
    assert np.isfinite(stats.entered[:]).all()
    uv, refl = caustics.view(SMALL_WH, SMALL_GH, 0.1, (0.4, 0.4, 5.0), values)
    assert np.isfinite(uv).all() and np.isfinite(refl).all()


def run_fluid(values):
    with fluid.Fluid(values) as f:
        p = f.params
        lo, hi = np.array(p.box_min[:]), np.array(p.box_max[:])
        c, s = (lo + hi) / 2, p.particle_spacing
        if p.source == 0:  # SIMULATE: a small block of fluid in the middle, if it fits
            if p.max_particles >= 216:
                f.fill_box(c - 2.5 * s, c + 2.5 * s)
        elif p.source == 1:  # PARTICLES
            n = min(200, p.max_particles)
            rng = np.random.default_rng(1)
            pos = c + (rng.random((n, 3)) - 0.5) * 0.4 * (hi - lo)
            f.set_particles(pos.astype(np.float32), np.zeros((n, 3), np.float32))
        else:  # VELOCITY_GRID
            nx, ny, nz = f.vertices
            vel = np.zeros((nz, ny, nx, 3), np.float32)
            vel[..., 0] = 0.1
            z, y, x = np.meshgrid(*(np.linspace(0, 1, n) for n in (nz, ny, nx)), indexing="ij")
            surf = (1.0 - 4 * ((x - .5) ** 2 + (y - .5) ** 2 + (z - .5) ** 2)).astype(np.float32)
            f.set_velocity_grid(vel, surf)
        f.step()
        m = f.surface()
        for a in m.values():
            assert np.isfinite(a).all()
        for name in ("uvw_a", "blend", "density"):
            assert np.isfinite(f.volume(name)).all()


RUN = {"rain": run_rain, "snow": run_snow, "water": run_water, "caustics": run_caustics,
       "fluid": run_fluid}


@pytest.mark.parametrize("effect, name, k, side", edge_cases())
def test_each_edge_of_the_range_runs(effect, name, k, side):
    spec = SPECS[effect]
    p = spec.by_name[name]
    label = f"{name}[{k}]" if p.count > 1 else name
    key = (effect, label, side.replace("_f32", ""))
    values = dict(BASE[effect])
    values.update(COMPANIONS.get(key, {}))
    values[name] = with_element(spec, name, k, edge_value(p, side), values)
    if key in VALIDATE_ONLY:
        s = spec.to_struct(values)  # the library's table check, hbk_params_validate
        assert getattr(s, name) == stored(p, edge_value(p, side))
        return
    if key in REFUSED:
        with pytest.raises(errors.InvalidArgument) as exc:
            RUN[effect](values)
        assert type(exc.value) is errors.InvalidArgument
        assert re.search(REFUSED[key], str(exc.value)), str(exc.value)
        return
    RUN[effect](values)


SPH_GRID = """
import sys
sys.path.insert(0, {addon!r})
from hydrobake.core import errors, fluid
try:
    f = fluid.Fluid({params!r})
except errors.InvalidArgument as exc:
    print("refused:", exc)
    raise SystemExit
s = f.params.particle_spacing
f.fill_box((0.2 - 2.5 * s,) * 3, (0.2 + 2.5 * s,) * 3)
print("particles:", fluid._lib.lib.hbk_fluid_particle_count(f.h))
try:
    f.step()
    print("ok")
except errors.HydrobakeError as exc:
    print(type(exc).__name__ + ":", exc)
"""


def test_the_sph_grid_the_checks_allow_fits_in_memory():
    """A box 0.4 m wide with h = 1e-4 m is 4000 kernel radii per axis, under the 4096 allowed,
    but its dense neighbour grid would be 4000^3 cells (256 GB): create must refuse it, naming
    smoothing_length, not fail in the step with "out of memory"."""
    # In a child process: under AddressSanitizer a failed allocation aborts unless
    # allocator_may_return_null is set.
    import subprocess
    import sys
    params = dict(BASE["fluid"], particle_spacing=TINY, smoothing_length=TINY,
                  metaball_radius=2e-4)
    code = SPH_GRID.format(addon=os.path.join(ROOT, "blender_addon"), params=params)
    env = dict(os.environ)
    env["ASAN_OPTIONS"] = ":".join(filter(None, [env.get("ASAN_OPTIONS"),
                                                 "allocator_may_return_null=1"]))
    r = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True,
                       timeout=120)
    assert r.returncode == 0, r.stderr[-3000:]
    out = r.stdout.strip()
    if out.startswith("refused: "):
        assert out.startswith("refused: smoothing_length = ") and \
            "at most 16777216 are allowed" in out, out
    else:
        first, _, rest = out.partition("\n")
        assert first.startswith("particles: ") and int(first.split()[1]) > 0, out
        assert rest.strip() == "ok", out


@pytest.mark.parametrize("kind, params, message", [
    ("water", dict(width=4097, height=4096),
     "width x height = 4097 x 4096: must be at most 16777216 cells (4096 x 4096)"),
    ("water", dict(width=16384, height=16384),
     "width x height = 16384 x 16384: must be at most 16777216 cells"),
    ("rain", dict(width=4096, height=4097, map_width=4096, map_height=4096),
     "width x height = 4096 x 4097: must be at most 16777216 cells (4096 x 4096)"),
    ("rain", dict(width=4096, height=4096, map_width=8192, map_height=8193),
     "map_width x map_height = 8192 x 8193: must be at most 67108864 texels (8192 x 8192)"),
])
def test_grids_past_a_workstations_memory_are_refused_before_allocating(kind, params, message):
    """Each side is within the table, but the product would need more memory than a
    workstation has (a 16384^2 caustics bake needs about 100 GB), and the system kills the
    process rather than let an allocation fail: create refuses it, naming both sides."""
    handle = HANDLES[kind]
    with pytest.raises(errors.InvalidArgument) as exc:
        handle(params)
    assert str(exc.value).startswith(message), str(exc.value)


def test_the_largest_rain_glass_is_created():
    """core.rain.MAX_CELLS (which the addon quotes for Grid From Mesh) is the C limit."""
    side = int(math.isqrt(rain.MAX_CELLS))
    r = rain.Rain(dict(width=side, height=side, map_width=side, map_height=side))
    r.close()
    with pytest.raises(errors.InvalidArgument, match=f"at most {rain.MAX_CELLS} cells"):
        rain.Rain(dict(width=side + 1, height=side, map_width=side, map_height=side))
