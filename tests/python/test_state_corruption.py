"""Checkpoints that are truncated, corrupted, of another effect or of another shape: every load
either succeeds (and the handle then steps without crashing) or is refused with the result code
its header documents, leaving the handle as it was. For rain, snow, water and fluid.

The layouts below are read off the loaders (c_core/src/rain/rain.c, snow/state.c,
water/water.c, fluid/state.c), so that the corruptions hit the header fields and the counts the
loaders trust. Run it against the sanitized build as well (build/test.sh does):
HYDROBAKE_LIB=build/_work/cmake-sanitize/libhydrobake.so with libasan/libubsan preloaded.

The loader bugs it found that could crash a step (or abort under UBSan) are run at the end in a
child process, so that a regression fails its case and not the whole run."""
import json
import os
import struct
import subprocess
import sys
from dataclasses import dataclass

import numpy as np
import pytest

import hydrobake
from hydrobake.core import _lib, errors, fluid, rain, snow, water

HERE = os.path.dirname(os.path.abspath(__file__))
ADDON = os.path.dirname(os.path.dirname(os.path.abspath(hydrobake.__file__)))
FLT_MAX = float(np.finfo(np.float32).max)
# The library was built with UBSan (build/test.sh's sanitized tree): undefined behaviour aborts.
UBSAN = hasattr(_lib.lib, "__ubsan_handle_add_overflow_abort")


# --- the four effects, each with a small handle that has run a few steps ------------------

@dataclass
class Field:
    """A header field: name, byte offset, struct format, role (what a change to it must give:
    magic/version -> FORMAT; shape -> the documented "other grid" code; size -> changes the
    bytes the state needs; free -> anything the loader takes; pad -> ignored)."""
    name: str
    off: int
    fmt: str
    role: str

    @property
    def size(self):
        return struct.calcsize("=" + self.fmt)


@dataclass
class Section:
    """A payload section: its float elements (dtype f4/f8, or None for bytes and records) and
    whether the header promises that a non-finite number there is refused (`refuse`: "all",
    "nan" where +-inf is a legal value, or None)."""
    name: str
    off: int
    nbytes: int
    dtype: object = None
    refuse: object = None


class Effect:
    name = ""
    cls = None
    params = {}
    other_code = None  # what the header documents for a state of another shape
    steps = 3
    short_code = errors.InvalidArgument  # header: a buffer too small for its header's counts

    def fresh(self, params=None):
        return self.cls(params or self.params)

    def make(self, steps=None, params=None):
        h = self.fresh(params)
        self.prepare(h)
        for _ in range(self.steps if steps is None else steps):
            self.advance(h)
        return h

    def prepare(self, h):
        pass

    def advance(self, h):
        raise NotImplementedError

    def outputs(self, h):
        raise NotImplementedError

    def header_size(self):
        raise NotImplementedError

    def fields(self, a):
        raise NotImplementedError

    def sections(self, a):
        raise NotImplementedError


def read(a, f):
    return struct.unpack_from("=" + f.fmt, a, f.off)[0]


class Rain(Effect):
    # A wiper, so that there are particles as well as drops, and a curved glass (tangent field
    # and mask), so that every optional section is in the state.
    name, cls = "rain", rain.Rain
    params = {"width": 32, "height": 24, "map_width": 64, "map_height": 48, "cell_size": 0.002,
              "rain_rate": 20000.0, "seed": 11, "wiper_count": 1,
              "wiper_pivot": (0.03, -0.005, 0.0, 0.0), "blade_length": 0.04,
              "blade_offset": 0.002, "wiper_period": 0.3, "threads": 1}
    other_code = errors.InvalidArgument  # "HBK_ERR_INVALID_ARGUMENT (other grid, too small)"
    steps = 8

    def prepare(self, h):
        H, W = h.params.height, h.params.width
        g = np.zeros((H, W, 2), np.float32)
        g[..., 1] = -1.0
        h.set_tangents(g, np.ones((H, W), np.float32))

    def advance(self, h):
        h.step(1 / 24)

    def outputs(self, h):
        w = h.water()
        return [h.heightmap(), h.wetness(), np.array([w[k] for k in sorted(w)], np.float64),
                np.array([[d["x"], d["y"], d["mass"]] for d in h.drops()], np.float32),
                np.array([list(b.values()) for b in h.blades()], np.float32)]

    def header_size(self):
        return 160

    def fields(self, a):
        F = Field
        return [F("magic", 0, "8s", "magic"), F("version", 8, "I", "version"),
                F("width", 12, "i", "shape"), F("height", 16, "i", "shape"),
                F("field_channels", 20, "i", "size"), F("has_mask", 24, "i", "size"),
                F("wiper_external", 28, "i", "free"),
                F("drop_count", 32, "q", "size"), F("particle_count", 40, "q", "size"),
                F("steps", 48, "Q", "free"), F("next_id", 56, "Q", "free"),
                F("time", 64, "d", "free"), F("rain_in", 72, "d", "free"),
                F("wiped", 80, "d", "free"), F("run_off", 88, "d", "free"),
                F("car_speed", 96, "f", "free"), F("car_accel", 100, "f", "free"),
                F("wind0", 104, "f", "free"), F("wind1", 108, "f", "free"),
                F("wiper_value0", 112, "f", "free"), F("wiper_value1", 116, "f", "free"),
                F("wiper_target0", 120, "f", "free"), F("wiper_target1", 124, "f", "free"),
                F("padding", 128, "32s", "pad")]

    def sections(self, a):
        d, p = read(a, Field("", 32, "q", "")), read(a, Field("", 40, "q", ""))
        fc, mask = read(a, Field("", 20, "i", "")), read(a, Field("", 24, "i", ""))
        n = self.params["width"] * self.params["height"]
        out, off = [], 160
        for s in (Section("drops", 0, 136 * d), Section("particles", 0, 16 * p),
                  Section("affinity", 0, 4 * n, "f4"), Section("film", 0, 8 * n, "f8"),
                  Section("wet_time", 0, 4 * n, "f4"), Section("field", 0, 4 * n * fc, "f4"),
                  Section("mask", 0, 4 * n * mask, "f4")):
            s.off = off
            off += s.nbytes
            out.append(s)
        return out


# Rain drop records (rain_drop_t, 136 bytes, saved byte for byte): x and y must lie on the
# grid (the loader refuses a drop off it: the occupancy would be written out of bounds).
DROP = 136
DROP_X, DROP_Y, DROP_MASS = 16, 20, 0
DROP_OFF = 48  # float off[8][2]: the sub-metaballs' offsets, in radii
PARTICLE = 16
PARTICLE_X, PARTICLE_Y, PARTICLE_MASS = 8, 12, 0


class Snow(Effect):
    name, cls = "snow", snow.Snow
    params = {"flake_count": 400, "texture_width": 16, "texture_height": 16, "threads": 1,
              "flake_radius": 0.02, "temperature": 0.5, "volume_min": (-1, -1, 0),
              "volume_max": (1, 1, 1)}
    other_code = errors.StateError  # "HBK_ERR_STATE (saved by a handle of another shape)"
    steps = 2
    short_code = errors.FormatError  # "HBK_ERR_FORMAT (... wrong version or size ...)"

    def prepare(self, h):
        # The header: set the mesh (and materials) before load_state.
        pos = np.array([[-1, -1, .5], [1, -1, .5], [1, 1, .5], [-1, 1, .5]], np.float32)
        tris = np.array([[0, 1, 2], [0, 2, 3]], np.int32)
        uvs = np.array([[[0, 0], [1, 0], [1, 1]], [[0, 0], [1, 1], [0, 1]]], np.float32)
        h.set_materials([(0.5, False, False)])
        h.set_mesh(pos, tris, uvs)

    def fresh(self, params=None):
        h = self.cls(params or self.params)
        self.prepare(h)
        return h

    def make(self, steps=None, params=None):
        h = self.fresh(params)
        for _ in range(self.steps if steps is None else steps):
            self.advance(h)
        return h

    def advance(self, h):
        h.step(10)

    def outputs(self, h):
        return [h.coverage(), h.depth(), h.flakes()]

    def header_size(self):
        return 136

    def fields(self, a):
        F = Field
        return [F("magic", 0, "8s", "magic"), F("version", 8, "I", "version"),
                F("header_size", 12, "I", "version"), F("flake_count", 16, "i", "shape"),
                F("tex_w", 20, "i", "shape"), F("tex_h", 24, "i", "shape"),
                F("blocks", 28, "i", "shape"), F("contact_mode", 32, "i", "shape"),
                F("flake_size", 36, "i", "version"), F("shelter_check", 40, "i", "free"),
                F("reserved", 44, "i", "pad"), F("step", 48, "Q", "free")] + \
            [F("stats." + n, 56 + 8 * i, "q", "free") for i, n in enumerate(
                ("substeps", "flake_steps", "hits", "stuck", "bounced", "melted", "shed",
                 "fell"))] + \
            [F("payload_bytes", 120, "Q", "size"), F("checksum", 128, "Q", "checksum")]

    def sections(self, a):
        n = self.params["flake_count"]
        t = self.params["texture_width"] * self.params["texture_height"]
        return [Section("flakes", 136, 40 * n), Section("coverage", 136 + 40 * n, 4 * t, "f4"),
                Section("depth", 136 + 40 * n + 4 * t, 4 * t, "f4")]


FLAKE = 40  # snow_flake_t: p[3], v[3], fc, fs, fall (float), cls (uint32)
FLAKE_CLS = 36


def fnv_words(x, data):
    """snow/state.c's hash_bytes: FNV-1a over 64-bit words, then the tail bytes."""
    m = (1 << 64) - 1
    n8 = len(data) // 8 * 8
    for w in np.frombuffer(data[:n8], np.uint64).tolist():
        x = ((x ^ w) * 0x100000001b3) & m
    for b in data[n8:]:
        x = ((x ^ b) * 0x100000001b3) & m
    return x


def snow_reseal(buf):
    """Rewrites the checksum of a snow state after a change to its payload, so that the change
    reaches the checks behind the checksum."""
    x = 0xcbf29ce484222325
    for s in SNOW.sections(buf):
        x = fnv_words(x, bytes(buf[s.off:s.off + s.nbytes]))
    struct.pack_into("=Q", buf, 128, x)
    return buf


class Water(Effect):
    # Sources, acceleration and footprint set, so that the optional sections are present.
    name, cls = "water", water.Water
    params = {"width": 16, "height": 12, "rain_rate": 50.0, "seed": 3, "threads": 1}
    other_code = errors.InvalidArgument  # "HBK_ERR_INVALID_ARGUMENT (other grid size, ...)"
    steps = 3

    def prepare(self, h):
        H, W = h.shape
        y, x = np.mgrid[0:H, 0:W]
        h.set_level(0.5)
        h.set_surface(np.where((x - 5) ** 2 + (y - 6) ** 2 < 8, 0.6, 0.5).astype(np.float32))
        h.set_sources(np.full((H, W), 0.001, np.float32))
        h.set_acceleration(np.full((H, W, 2), 0.01, np.float32))
        h.set_footprint(np.where(x < 3, 0.05, 0.0).astype(np.float32))

    def advance(self, h):
        h.step()

    def outputs(self, h):
        return [h.surface(), h.depth(), h.velocity(), np.array([h.volume()])]

    def header_size(self):
        return 32

    def fields(self, a):
        F = Field
        return [F("magic", 0, "8s", "magic"), F("version", 8, "I", "version"),
                F("width", 12, "i", "shape"), F("height", 16, "i", "shape"),
                F("flags", 20, "I", "free"), F("steps", 24, "Q", "free")]

    def sections(self, a):
        n = self.params["width"] * self.params["height"]
        out, off = [], 32
        # The header: "HBK_ERR_FORMAT (... invalid numbers)".
        for name, size, dt, k in (("ground", 4, "f4", 1), ("depth", 8, "f8", 1),
                                  ("vel_x", 8, "f8", 1), ("vel_y", 8, "f8", 1),
                                  ("sources", 4, "f4", 1), ("accel", 4, "f4", 2),
                                  ("footprint", 4, "f4", 1)):
            out.append(Section(name, off, size * k * n, dt, "all"))
            off += size * k * n
        return out


class Fluid(Effect):
    # SPH particles in a box, an obstacle, a painted ball and a feature rule.
    name, cls = "fluid", fluid.Fluid
    params = {"resolution": (8, 8, 8), "box_max": (0.4, 0.4, 0.4), "particle_spacing": 0.03,
              "smoothing_length": 0.06, "metaball_radius": 0.06, "max_particles": 400,
              "substeps": 2, "textures": 2, "threads": 1, "dt": 1 / 48}
    other_code = errors.InvalidArgument  # "HBK_ERR_INVALID_ARGUMENT (other grid, ...)"
    steps = 2

    def prepare(self, h):
        h.fill_box((0.0, 0.0, 0.0), (0.15, 0.15, 0.15))
        h.set_obstacles([("sphere", (0.3, 0.3, 0.1), 0.05), ("box", (0.1, 0.3, 0.1),
                                                              (0.05, 0.05, 0.05)),
                         ("turned_box", (0.3, 0.1, 0.1), (0.05, 0.02, 0.05),
                          (np.cos(0.3), 0.0, 0.0, np.sin(0.3))),
                         ("mesh", (0.3, 0.3, 0.3), (0.06, 0.06, 0.06), (1.0, 0.0, 0.0, 0.0),
                          MESH_FIELD)])
        h.paint_sphere(1, (0.07, 0.07, 0.07), 0.05, 0.01)
        lo, hi = [-FLT_MAX] * 6, [FLT_MAX] * 6
        lo[0], hi[0] = 0.0, 0.5
        h.set_feature_rule(0, lo, hi)

    def advance(self, h):
        h.step()

    def outputs(self, h):
        pos, vel = h.particles()
        m = h.surface()
        return [pos, vel, h.volume("uvw_a"), h.volume("blend"), h.volume("density"),
                h.volume("features"), m["positions"], m["uvw_a"], m["blend"]]

    def header_size(self):
        return 64

    def fields(self, a):
        F = Field
        return [F("magic", 0, "8s", "magic"), F("version", 8, "I", "version"),
                F("res0", 12, "i", "shape"), F("res1", 16, "i", "shape"),
                F("res2", 20, "i", "shape"), F("textures", 24, "i", "shape"),
                F("max_particles", 28, "i", "free"), F("count", 32, "i", "size"),
                F("n_obs", 36, "i", "free"), F("have_fields", 40, "i", "free"),
                F("paint_active", 44, "i", "free"), F("has_in_vel", 48, "i", "size"),
                F("has_in_surface", 52, "i", "size"), F("frame", 56, "Q", "free")]

    def sections(self, a):
        count = read(a, Field("", 32, "i", ""))
        has_vel, has_surf = read(a, Field("", 48, "i", "")), read(a, Field("", 52, "i", ""))
        nv = 1
        for r in self.params["resolution"]:
            nv *= r + 1
        nvox = int(np.prod(self.params["resolution"]))
        K, F = self.params["textures"], len(fluid.FEATURES)
        # The header: "HBK_ERR_FORMAT (not a fluid state, other version, bad numbers)". The
        # feature rules may hold +-inf (hbk_fluid_set_feature_rule takes any lo <= hi but NaN).
        out, off = [], 64
        for name, nbytes, dt, refuse in (
                ("pos", 12 * count, "f4", "all"), ("vel", 12 * count, "f4", "all"),
                ("obstacles", 64 * OBSTACLE, None, None),
                ("in_vel", 12 * nv if has_vel else 0, "f4", "all"),
                ("in_surface", 4 * nv if has_surf else 0, "f4", "all"),
                ("uvw_a", 12 * nv, "f4", "all"), ("uvw_b", 12 * nv, "f4", "all"),
                ("wrap_a", nvox, None, None), ("wrap_b", nvox, None, None),
                ("base", 4 * K * nv, "f4", "all"), ("paint", 4 * K * nv, "f4", "all"),
                ("life", 4 * nv, "f4", "all"), ("motion", 12 * nv, "f4", "all"),
                ("density", 4 * nv, "f4", "all"), ("surface", 4 * nv, "f4", "all"),
                ("features", 4 * F * nv, "f4", "all"), ("rule_on", 4 * 8, None, None),
                ("rule_lo", 4 * 8 * F, "f4", "nan"), ("rule_hi", 4 * 8 * F, "f4", "nan"),
                ("field_dims", 12 * 64, None, None),
                ("fields", 4 * MESH_FIELD.size, "f4", "all")):
            out.append(Section(name, off, nbytes, dt, refuse))
            off += nbytes
        return out


OBSTACLE = 44  # hbk_fluid_obstacle_t: type (int32), center[3], extent[3], rotation[4]
# The mesh obstacle's field: a ball's distances (the state ends with it, after the dims).
MESH_FIELD = (np.linalg.norm(np.stack(np.meshgrid(*[np.linspace(-0.06, 0.06, 4)] * 3,
                                                  indexing="ij")), axis=0) -
              0.04).astype(np.float32)

RAIN, SNOW, WATER, FLUID = Rain(), Snow(), Water(), Fluid()
EFFECTS = [RAIN, SNOW, WATER, FLUID]
IDS = [e.name for e in EFFECTS]


class States:
    """Per effect, built once: A (the saved state of a run) and B (the same params a few steps
    further), and a target handle that holds B."""

    def __init__(self, e):
        self.e = e
        h = e.make()
        self.a = bytes(h.save_state())
        e.advance(h)
        e.advance(h)
        self.b = bytes(h.save_state())
        h.close()
        assert self.a != self.b
        self.target = e.fresh()
        self.reset()

    def reset(self):
        self.target.load_state(self.b)
        return self.target


_STATES = {}


def states(e):
    if e.name not in _STATES:
        _STATES[e.name] = States(e)
    return _STATES[e.name]


@pytest.fixture(params=EFFECTS, ids=IDS)
def effect(request):
    return request.param


def refused(h, data, allowed):
    """Loads `data`, which must be refused with one of the `allowed` exception classes and a
    detail message; returns the exception."""
    with pytest.raises(errors.HydrobakeError) as info:
        h.load_state(data)
    exc = info.value
    assert type(exc) in allowed, f"{type(exc).__name__}: {exc}"
    assert str(exc).strip(), "no detail message"
    return exc


# --- corruptions ----------------------------------------------------------------------------

NAN32, INF32, NINF32 = 0x7FC00000, 0x7F800000, 0xFF800000
NAN64, INF64, NINF64 = 0x7FF8000000000000, 0x7FF0000000000000, 0xFFF0000000000000
EXTREME = {4: [0, 1, 0xFFFFFFFF, 0x7FFFFFFF, 0x80000000, NAN32, INF32, NINF32, 0x00010000],
           8: [0, 1, (1 << 64) - 1, (1 << 63) - 1, 1 << 63, NAN64, INF64, NINF64, 1 << 32,
               1 << 40, (1 << 40) + 1]}
UINT = {4: "I", 8: "Q"}
FLOATS = {"f4": (4, "f", [float("nan"), float("inf"), float("-inf"), 3e38, -3e38]),
          "f8": (8, "d", [float("nan"), float("inf"), float("-inf"), 1e300, -1e300])}


@dataclass
class Variant:
    label: str
    data: bytes
    resealed: bool = False  # snow: the checksum was rewritten after the change


def poke(a, off, fmt, value):
    buf = bytearray(a)
    struct.pack_into("=" + fmt, buf, off, value)
    return bytes(buf)


def corruptions(e, a, seed):
    """A few hundred deterministic variants of state `a`: every header field at the extremes,
    the counts off by a little and a lot, bit flips and overwritten bytes (header and payload),
    extreme words in the payload, non-finite numbers in each float section, and the records the
    loaders check (or trust) given values off the grid, NaN, huge."""
    rng = np.random.default_rng(seed)
    out = []
    hs = e.header_size()
    for f in e.fields(a):
        if f.role == "pad":
            out.append(Variant(f"{f.name} = 0xff..", poke(a, f.off, f"{f.size}s",
                                                         b"\xff" * f.size)))
            continue
        if f.role == "magic":
            for i in range(f.size):
                buf = bytearray(a)
                buf[f.off + i] ^= 0x20
                out.append(Variant(f"magic[{i}] ^ 0x20", bytes(buf)))
            continue
        for v in EXTREME[f.size]:
            if struct.pack("=" + UINT[f.size], v) != a[f.off:f.off + f.size]:
                out.append(Variant(f"{f.name} = {v:#x}", poke(a, f.off, UINT[f.size], v)))
        if f.role in ("size", "shape") and f.fmt in "iIqQ":
            n = read(a, f)
            for v in {n + 1, n - 1, n + 2, n - 2, 2 * n, n // 2, -n, n + (1 << 31)}:
                mask = (1 << (8 * f.size)) - 1
                packed = v & mask
                if packed != n & mask:
                    out.append(Variant(f"{f.name} = {v}", poke(a, f.off, UINT[f.size], packed)))
    for lo, hi, count in ((0, hs, 60), (0, len(a), 60)):  # the header, anywhere
        for _ in range(count):
            bit = int(rng.integers(lo * 8, hi * 8))
            buf = bytearray(a)
            buf[bit // 8] ^= 1 << (bit % 8)
            out.append(Variant(f"bit {bit // 8}.{bit % 8} flipped", bytes(buf)))
    for lo, hi, count in ((0, hs, 30), (0, len(a), 30)):
        for _ in range(count):
            n = int(rng.integers(1, 9))
            off = int(rng.integers(lo, hi - n + 1))
            buf = bytearray(a)
            buf[off:off + n] = rng.integers(0, 256, n, dtype=np.uint8).tobytes()
            out.append(Variant(f"bytes {off}..{off + n - 1} overwritten", bytes(buf)))
    for _ in range(60):
        size = int(rng.choice([4, 8]))
        off = int(rng.integers(hs // size, len(a) // size)) * size
        v = EXTREME[size][int(rng.integers(0, len(EXTREME[size])))]
        out.append(Variant(f"word {off} ({size} B) = {v:#x}", poke(a, off, UINT[size], v)))
    for s in e.sections(a):
        if s.dtype is None or s.nbytes == 0:
            continue
        size, fmt, values = FLOATS[s.dtype]
        for v in values:
            i = int(rng.integers(0, s.nbytes // size))
            out.append(Variant(f"{s.name}[{i}] = {v}", poke(a, s.off + size * i, fmt, v)))
    out += e.special(a, rng)
    return [v for v in out if v.data != a]  # (an extreme value may be the value already)


def rain_special(a, rng):
    out = []
    secs = {s.name: s for s in RAIN.sections(a)}
    W, H = RAIN.params["width"], RAIN.params["height"]
    d, p = secs["drops"], secs["particles"]
    for rec, size, n, fields in (
            ("drop", DROP, d.nbytes // DROP, ((DROP_X, W), (DROP_Y, H))),
            ("particle", PARTICLE, p.nbytes // PARTICLE, ((PARTICLE_X, W), (PARTICLE_Y, H)))):
        base = d.off if rec == "drop" else p.off
        assert n > 0, f"no {rec}s in the state"
        for k, (off, lim) in zip("xy", fields):
            for v in (-1.0, -1e-3, float(lim), lim + 0.5, 1e30, -1e30, float("nan"),
                      float("inf"), 2.0 ** 31):
                i = int(rng.integers(0, n))
                out.append(Variant(f"{rec}[{i}].{k} = {v}",
                                   poke(a, base + size * i + off, "f", v)))
        mass_off = DROP_MASS if rec == "drop" else PARTICLE_MASS
        for v in (float("nan"), -1.0, 0.0, 1e300, float("inf")):
            i = int(rng.integers(0, n))
            out.append(Variant(f"{rec}[{i}].mass = {v}", poke(a, base + size * i + mass_off,
                                                              "d", v)))
    n = d.nbytes // DROP
    for off, name, fmt, values in ((44, "flags", "I", (0xFFFFFFFF, 2, 3)),
                                   (40, "moves", "I", (0xFFFFFFFF,)),
                                   (8, "id", "Q", ((1 << 64) - 1,)),
                                   (24, "speed", "f", (float("nan"), 1e30, -1e30)),
                                   (28, "travel", "f", (float("nan"), 1e30, -1e30)),
                                   (32, "age", "f", (float("nan"), -1e30)),
                                   (36, "mass0", "f", (float("nan"), -1.0)),
                                   (48, "off[0][0]", "f", (float("nan"), 1e30)),
                                   (112, "rest[0]", "H", (0x8080,)),
                                   (128, "scale[0]", "B", (255,))):
        for v in values:
            i = int(rng.integers(0, n))
            out.append(Variant(f"drop[{i}].{name} = {v}", poke(a, d.off + DROP * i + off,
                                                               fmt, v)))
    for i, j in ((0, 1), (1, 0), (n - 1, 0)):  # two drops in one cell
        buf = bytearray(a)
        at, src = d.off + DROP * i + DROP_X, d.off + DROP * j + DROP_X
        buf[at:at + 8] = a[src:src + 8]
        out.append(Variant(f"drop[{i}] moved onto drop[{j}]", bytes(buf)))
    return out


def snow_special(a, rng):
    out = []
    fl = SNOW.sections(a)[0]
    n = fl.nbytes // FLAKE
    for off, name, fmt, values in (
            (0, "p[0]", "f", (float("nan"), float("inf"), 1e30, -1e30)),
            (8, "p[2]", "f", (float("nan"), -float("inf"), 1e30, -1e30, -5.0)),
            (12, "v[0]", "f", (float("nan"), float("inf"), 1e30)),
            (20, "v[2]", "f", (float("nan"), -1e30)),
            (24, "fc", "f", (float("nan"), 1e30)),
            (28, "fs", "f", (float("inf"),)),
            (32, "fall", "f", (float("nan"), -1.0, 1e30, 0.0)),
            (FLAKE_CLS, "cls", "I", (31, 32, 0xFFFFFFFF))):
        for v in values:
            i = int(rng.integers(0, n))
            buf = snow_reseal(bytearray(poke(a, fl.off + FLAKE * i + off, fmt, v)))
            out.append(Variant(f"flake[{i}].{name} = {v} (resealed)", bytes(buf), True))
    for s in SNOW.sections(a)[1:]:
        for v in (float("nan"), float("inf"), -1.0, 1e30, -1e30):
            i = int(rng.integers(0, s.nbytes // 4))
            buf = snow_reseal(bytearray(poke(a, s.off + 4 * i, "f", v)))
            out.append(Variant(f"{s.name}[{i}] = {v} (resealed)", bytes(buf), True))
    for _ in range(30):
        bit = int(rng.integers(136 * 8, len(a) * 8))
        buf = bytearray(a)
        buf[bit // 8] ^= 1 << (bit % 8)
        out.append(Variant(f"bit {bit // 8}.{bit % 8} flipped (resealed)",
                           bytes(snow_reseal(buf)), True))
    return out


def water_special(a, rng):
    out = []
    for flags in (0, 1, 2, 4, 0xFFFFFFF8, 0xFFFFFFFF):
        out.append(Variant(f"flags = {flags:#x}", poke(a, 20, "I", flags)))
    secs = {s.name: s for s in WATER.sections(a)}
    for v in (-1e-3, 1e9, 1e300):  # the loader wants 0 <= depth < 1e9
        i = int(rng.integers(0, secs["depth"].nbytes // 8))
        out.append(Variant(f"depth[{i}] = {v}", poke(a, secs["depth"].off + 8 * i, "d", v)))
    return out


def fluid_special(a, rng):
    out = []
    secs = {s.name: s for s in FLUID.sections(a)}
    ob = secs["obstacles"]
    for i in (0, 1):
        at = ob.off + OBSTACLE * i
        for v in (2, -1, 0x7FFFFFFF):
            out.append(Variant(f"obstacle[{i}].type = {v}", poke(a, at, "i", v)))
        for off, name in ((4, "center[0]"), (16, "extent[0]"), (20, "extent[1]")):
            for v in (float("nan"), float("inf"), -1.0, 1e30):
                out.append(Variant(f"obstacle[{i}].{name} = {v}", poke(a, at + off, "f", v)))
    dims = secs["field_dims"].off  # the mesh's field: out of range, or given to a box
    for o, k, v in ((3, 0, 1), (3, 1, 200), (3, 2, -4), (3, 0, 1 << 30), (1, 0, 2), (0, 2, 2)):
        out.append(Variant(f"field_dims[{o}][{k}] = {v}", poke(a, dims + 12 * o + 4 * k, "i", v)))
    at = ob.off + OBSTACLE * 2  # the turned box: a rotation that is not a unit quaternion
    for off in (28, 40):
        for v in (float("nan"), float("inf"), 1.5, 0.0):
            out.append(Variant(f"obstacle[2].rotation[{(off - 28) // 4}] = {v}",
                               poke(a, at + off, "f", v)))
    for name in ("wrap_a", "wrap_b"):
        s = secs[name]
        for v in (0xFF, 0x80, 0x08, 0x07):
            i = int(rng.integers(0, s.nbytes))
            out.append(Variant(f"{name}[{i}] = {v:#x}", poke(a, s.off + i, "B", v)))
    n = secs["pos"].nbytes // 12
    for name in ("pos", "vel"):
        for v in (1e30, -1e30, 5.0, -5.0, 3e38):
            i = int(rng.integers(0, 3 * n))
            out.append(Variant(f"{name}[{i}] = {v}", poke(a, secs[name].off + 4 * i, "f", v)))
    # Fewer particles, so that the freed bytes hold the optional inputs the header now says
    # are there (an SPH handle given a velocity grid's surface field).
    for count, vel, surf in ((0, 0, 1), (0, 1, 0), (0, 1, 1), (n - 100, 0, 1)):
        buf = bytearray(a)
        struct.pack_into("=i", buf, 32, count)
        struct.pack_into("=ii", buf, 48, vel, surf)
        out.append(Variant(f"count = {count}, has_in_vel = {vel}, has_in_surface = {surf}",
                           bytes(buf)))
    for t, v in ((0, 0x7FFFFFFF), (1, -1), (7, 1)):
        out.append(Variant(f"rule_on[{t}] = {v}", poke(a, secs["rule_on"].off + 4 * t, "i", v)))
    return out


RAIN.special, SNOW.special = staticmethod(rain_special), staticmethod(snow_special)
WATER.special, FLUID.special = staticmethod(water_special), staticmethod(fluid_special)


# --- what a variant must give -----------------------------------------------------------------

@dataclass
class Expect:
    allowed: set         # exception classes a refusal may raise
    refuse: list         # reasons it must be refused (empty: it may load)
    finite: bool         # if it loads, the outputs after a step must be finite
    same: bool           # if it loads, it must save back to the unchanged state


def floats(data, s):
    return np.frombuffer(data, np.dtype(s.dtype), s.nbytes // np.dtype(s.dtype).itemsize,
                         s.off)


def expect(e, a, v):
    """The outcomes the header documents for variant v (of state a)."""
    x, y = np.frombuffer(a, np.uint8), np.frombuffer(v.data, np.uint8)
    changed = np.nonzero(x != y)[0]
    assert len(changed), v.label

    def hit(off, n):
        return n > 0 and bool(np.any((changed >= off) & (changed < off + n)))

    fields = [f for f in e.fields(a) if hit(f.off, f.size)]
    sections = [s for s in e.sections(a) if hit(s.off, s.nbytes)]
    roles = {f.role for f in fields}
    allowed, refuse = {errors.FormatError}, []
    # Codes other than FORMAT only where the header documents them: a changed grid, texture
    # or flake count is "another shape" (INVALID_ARGUMENT "other grid" for rain, water and
    # fluid; STATE for snow), and a changed count or flag that makes the state need more bytes
    # than it has is "too small" (INVALID_ARGUMENT; snow: FORMAT "wrong size").
    if "shape" in roles:
        allowed.add(e.other_code)
    if "size" in roles:
        allowed.add(e.short_code)
    if roles & {"magic", "version"}:
        refuse.append("magic or version")
    if e is SNOW:
        if (sections or "checksum" in roles) and not v.resealed:
            refuse.append("checksum")
        if "size" in roles:
            refuse.append("payload size")
    if "size" not in roles:  # the sections are where `a` has them
        for s in sections:
            if s.dtype is None or not s.refuse:
                continue
            before, after = floats(a, s), floats(v.data, s)
            bad = np.isnan(after) if s.refuse == "nan" else ~np.isfinite(after)
            if np.any(bad & ~(np.isnan(before) if s.refuse == "nan" else ~np.isfinite(before))):
                refuse.append(f"non-finite {s.name}")
        if e is RAIN and sections and sections[0].name == "drops":
            # rain.c: "Every drop must sit in a cell of the grid" (FORMAT otherwise).
            d = sections[0]
            rec = np.frombuffer(v.data, np.float32, d.nbytes // 4, d.off).reshape(-1, DROP // 4)
            xs, ys = rec[:, DROP_X // 4], rec[:, DROP_Y // 4]
            if not np.all((xs >= 0) & (xs < e.params["width"]) & (ys >= 0) &
                          (ys < e.params["height"])):
                refuse.append("drop off the grid")
        if e is SNOW and v.resealed and sections and sections[0].name == "flakes":
            # state.c: a flake with a non-finite position or a flutter class past 31.
            s = sections[0]
            f = np.frombuffer(v.data, np.float32, s.nbytes // 4, s.off).reshape(-1, FLAKE // 4)
            cls = f[:, FLAKE_CLS // 4].view(np.uint32)
            if not np.all(np.isfinite(f[:, :3])) or np.any(cls >= 32):
                refuse.append("flake not valid")
    ints_only = not sections and all(f.role in ("free", "pad") and f.fmt in "iIqQ32s"
                                     for f in fields)
    same = not sections and all(f.role == "pad" for f in fields)
    return Expect(allowed, refuse, ints_only, same)


def all_finite(arrays):
    return all(np.all(np.isfinite(np.asarray(x, np.float64))) for x in arrays)


def check_variant(e, s, v):
    """Loads variant v into the target handle (which holds state B) and checks the outcome
    against expect(). Returns "refused" or "loaded"; leaves the target holding B."""
    ex = expect(e, s.a, v)
    h = s.target
    try:
        h.load_state(v.data)
    except errors.HydrobakeError as exc:
        assert type(exc) in ex.allowed, \
            f"{e.name}: {v.label}: {type(exc).__name__} ({exc}), allowed " \
            f"{sorted(c.__name__ for c in ex.allowed)}"
        assert str(exc).strip(), f"{e.name}: {v.label}: no detail message"
        after = bytes(h.save_state())
        assert after == s.b, f"{e.name}: {v.label}: the failed load changed the handle"
        return "refused"
    assert not ex.refuse, f"{e.name}: {v.label}: loaded, must be refused ({ex.refuse})"
    if ex.same:
        assert bytes(h.save_state()) == s.a, f"{e.name}: {v.label}: ignored bytes mattered"
    e.advance(h)
    out = e.outputs(h)
    if ex.finite:
        assert all_finite(out), f"{e.name}: {v.label}: loaded, then non-finite outputs"
    h.load_state(s.b)
    return "loaded"


INT64_MAX = (1 << 63) - 1


# --- 1. round trip --------------------------------------------------------------------------

def test_round_trip_is_bit_identical_and_continues(effect):
    s = states(effect)
    h = effect.fresh()
    h.load_state(s.a)
    assert bytes(h.save_state()) == s.a
    # It continues as the run that saved it: two steps on, it is that run's state B.
    effect.advance(h)
    effect.advance(h)
    assert bytes(h.save_state()) == s.b
    h.close()


# --- 2. truncations -------------------------------------------------------------------------

def cut_lengths(e, a):
    """0, 1, every header field's and section's boundaries (and a byte either side), a random
    sample and len - 1."""
    hs = e.header_size()
    cuts = {0, 1, 4, 7, 8, 12, hs - 1, hs, hs + 1, len(a) - 8, len(a) - 1}
    for f in e.fields(a):
        cuts |= {f.off, f.off + f.size}
    for s in e.sections(a):
        cuts |= {s.off - 1, s.off, s.off + 1, s.off + s.nbytes - 1, s.off + s.nbytes}
    cuts |= set(np.random.default_rng(7).integers(0, len(a), 40).tolist())
    return sorted(c for c in cuts if 0 <= c < len(a))


def truncation_code(e, n):
    """Shorter than the header it is not a state: FORMAT. Longer, the headers document "too
    small": HBK_ERR_INVALID_ARGUMENT for rain, water and fluid, HBK_ERR_FORMAT ("wrong ...
    size") for snow."""
    return errors.FormatError if n < e.header_size() else e.short_code


def test_truncated_states_are_refused_and_change_nothing(effect):
    s = states(effect)
    h = s.reset()
    cuts = cut_lengths(effect, s.a)
    assert len(cuts) > 60
    for n in cuts:
        exc = refused(h, s.a[:n], {truncation_code(effect, n)})
        assert bytes(h.save_state()) == s.b, f"cut at {n} ({exc}) changed the handle"


def test_null_buffer_is_an_invalid_argument(effect):
    h = states(effect).reset()
    for size in (0, 100000):  # straight through ctypes: the binding always passes a buffer
        with pytest.raises(errors.InvalidArgument, match="NULL"):
            h.call("load_state", None, size)
    assert bytes(h.save_state()) == states(effect).b


# --- 3. corruptions -------------------------------------------------------------------------

def test_corrupted_states_load_or_are_refused_as_documented(effect):
    """A few hundred deterministic corruptions. Each either loads (and then steps, with finite
    outputs where only integer fields changed) or is refused with a documented code, the
    handle unchanged; the ones the header says are refused must be."""
    s = states(effect)
    s.reset()
    variants = corruptions(effect, s.a, seed=100 + EFFECTS.index(effect))
    assert len(variants) > 250
    outcomes, failures = {"refused": 0, "loaded": 0}, []
    for v in variants:
        try:
            outcomes[check_variant(effect, s, v)] += 1
        except AssertionError as exc:
            failures.append(str(exc).splitlines()[0])
            s.reset()
    assert not failures, f"{len(failures)} of {len(variants)}:\n" + "\n".join(failures[:30])
    # Both happen: the corruptions reach past the header checks.
    assert outcomes["refused"] > 50 and outcomes["loaded"] > 50, outcomes


# The numbers the loaders check themselves (and the header's promise where it makes one).
LOADER_CHECKS = [
    # rain.c: "Every drop must sit in a cell of the grid" -> FORMAT.
    ("rain", "drops", DROP_X, "f", v, errors.FormatError)
    for v in (-0.5, 32.0, float("nan"), float("inf"))] + [
    ("rain", "drops", DROP_Y, "f", v, errors.FormatError) for v in (-1e-3, 24.0, float("nan"))
] + [
    # ... and so must every particle (one at 1e30 overflowed its cell index: UBSan).
    ("rain", "particles", PARTICLE_X, "f", v, errors.FormatError) for v in (-0.5, 32.0, 1e30)
] + [
    ("rain", "particles", PARTICLE_Y, "f", v, errors.FormatError) for v in (-1e30, 24.0)
] + [
    # water.c: ground, depth and velocities finite, 0 <= depth < 1e9 -> FORMAT.
    ("water", "depth", 0, "d", v, errors.FormatError) for v in (-1e-9, 1e9, float("nan"))
] + [
    ("water", "ground", 0, "f", float("inf"), errors.FormatError),
    ("water", "vel_y", 8, "d", float("-inf"), errors.FormatError),
    # fluid/state.c: the particle count within max_particles (INVALID_ARGUMENT: capacity),
    # at most 64 obstacles (FORMAT), particles finite (FORMAT).
    ("fluid", None, 32, "i", 401, errors.InvalidArgument),
    ("fluid", None, 32, "i", -1, errors.InvalidArgument),
    ("fluid", None, 36, "i", 65, errors.FormatError),
    ("fluid", None, 36, "i", -1, errors.FormatError),
    ("fluid", "pos", 4, "f", float("nan"), errors.FormatError),
    ("fluid", "vel", 8, "f", float("-inf"), errors.FormatError),
]


@pytest.mark.parametrize("name,section,off,fmt,value,code", LOADER_CHECKS,
                         ids=[f"{c[0]}-{c[1]}+{c[2]}={c[4]}" for c in LOADER_CHECKS])
def test_loader_checks(name, section, off, fmt, value, code):
    e = {x.name: x for x in EFFECTS}[name]
    s = states(e)
    h = s.reset()
    base = {x.name: x for x in e.sections(s.a)}[section].off if section else 0
    refused(h, poke(s.a, base + off, fmt, value), {code})
    assert bytes(h.save_state()) == s.b


def test_snow_flakes_behind_a_good_checksum_are_still_checked():
    """state.c checks each flake after the checksum: a position that is not finite, or a flutter
    class past 31, is FORMAT even in a state whose checksum was rewritten to match."""
    s = states(SNOW)
    h = s.reset()
    fl = SNOW.sections(s.a)[0]
    for off, fmt, value in ((0, "f", float("nan")), (8, "f", float("inf")), (FLAKE_CLS, "I", 32)):
        data = bytes(snow_reseal(bytearray(poke(s.a, fl.off + 7 * FLAKE + off, fmt, value))))
        refused(h, data, {errors.FormatError})
        assert bytes(h.save_state()) == s.b
    # Without the new checksum, any change is refused.
    refused(h, poke(s.a, fl.off + 4, "f", 0.25), {errors.FormatError})


# Per float section: the header's promise (water: "invalid numbers", fluid: "bad numbers" are
# HBK_ERR_FORMAT). The loaders check only some sections.
BAD_NUMBERS = [("water", n) for n in ("ground", "depth", "vel_x", "vel_y", "sources", "accel",
                                      "footprint")] + \
              [("fluid", n) for n in ("pos", "vel", "obstacles", "uvw_a", "uvw_b", "base",
                                      "paint", "life", "motion", "density", "surface",
                                      "features", "rule_lo", "rule_hi")]


@pytest.mark.parametrize("name,section", BAD_NUMBERS, ids=[f"{a}-{b}" for a, b in BAD_NUMBERS])
def test_bad_numbers_are_refused(name, section):
    e = {x.name: x for x in EFFECTS}[name]
    s = states(e)
    h = s.reset()
    sec = {x.name: x for x in e.sections(s.a)}[section]
    if section == "obstacles":  # the live ones: a sphere (center, radius), a box (center, half)
        spots = [(sec.off + off, "f") for off in (4, 12, 16)] + \
            [(sec.off + OBSTACLE + off, "f") for off in (8, 16, 24)]
        values = [float("nan"), float("inf")]
    else:
        size = np.dtype(sec.dtype).itemsize
        n = sec.nbytes // size
        spots = [(sec.off + size * i, "f" if size == 4 else "d") for i in (0, n // 2, n - 1)]
        values = [float("nan")] if sec.refuse == "nan" else \
            [float("nan"), float("inf"), float("-inf")]
    loaded = []
    for off, fmt in spots:
        for value in values:
            try:
                h.load_state(poke(s.a, off, fmt, value))
            except errors.FormatError as exc:
                assert str(exc).strip()
                assert bytes(h.save_state()) == s.b
                continue
            loaded.append(f"{section} +{off - sec.off} = {value}")
            h = s.reset()
    assert not loaded, f"loaded, must be HBK_ERR_FORMAT: {loaded}"


def test_fluid_feature_rules_may_hold_infinities():
    """hbk_fluid_set_feature_rule takes -inf/inf bounds (the header: -FLT_MAX / FLT_MAX for a
    feature that does not matter), so a state with them is not a bad-numbers state."""
    s = states(FLUID)
    h = s.reset()
    lo = {x.name: x for x in FLUID.sections(s.a)}["rule_lo"]
    h.load_state(poke(poke(s.a, lo.off, "f", float("-inf")), lo.off + 4 * 6 * 8, "f",
                      float("inf")))
    FLUID.advance(h)
    assert all_finite(FLUID.outputs(h))
    s.reset()


# --- 4. foreign states and other shapes -----------------------------------------------------

@pytest.mark.parametrize("src,dst", [(a, b) for a in IDS for b in IDS if a != b],
                         ids=[f"{a}-into-{b}" for a in IDS for b in IDS if a != b])
def test_another_effects_state_is_refused(src, dst):
    by = {x.name: x for x in EFFECTS}
    s, t = states(by[src]), states(by[dst])
    h = t.reset()
    refused(h, s.a, {errors.FormatError})
    # Also past the magic: a foreign state under this effect's magic and version. Its bytes
    # then read as this effect's grid and counts, so "other grid" and "too small" (the codes
    # the header documents for those) are as right as FORMAT; it must not load.
    head = t.b[:12]
    refused(h, head + s.a[12:], {errors.FormatError, by[dst].other_code, by[dst].short_code})
    assert bytes(h.save_state()) == t.b


OTHER_SHAPES = [
    (RAIN, dict(RAIN.params, width=40, map_width=80), errors.InvalidArgument),
    (RAIN, dict(RAIN.params, height=20), errors.InvalidArgument),
    (SNOW, dict(SNOW.params, texture_width=32), errors.StateError),
    (SNOW, dict(SNOW.params, flake_count=300), errors.StateError),
    (SNOW, dict(SNOW.params, contact_mode="BOX"), errors.StateError),
    (WATER, dict(WATER.params, height=14), errors.InvalidArgument),
    (WATER, dict(WATER.params, width=12), errors.InvalidArgument),
    (FLUID, dict(FLUID.params, resolution=(8, 8, 10)), errors.InvalidArgument),
    (FLUID, dict(FLUID.params, textures=3), errors.InvalidArgument),
]


@pytest.mark.parametrize("e,params,code", OTHER_SHAPES,
                         ids=[f"{e.name}-{k}" for e, p, c in OTHER_SHAPES
                              for k in [next(k for k in p if p[k] != e.params.get(k))]])
def test_a_state_of_another_shape_is_refused_with_the_documented_code(e, params, code):
    """rain, water: "HBK_ERR_INVALID_ARGUMENT (other grid ...)"; fluid: "(other grid, textures
    or capacity)"; snow: "HBK_ERR_STATE (saved by a handle of another shape)"."""
    s = states(e)
    other = e.make(params=params, steps=1)
    data = bytes(other.save_state())
    refused(s.reset(), data, {code})  # theirs into ours
    assert bytes(s.target.save_state()) == s.b
    before = bytes(other.save_state())
    refused(other, s.a, {code})  # and ours into theirs
    assert bytes(other.save_state()) == before
    other.close()


def test_a_fluid_state_with_more_particles_than_the_capacity_is_refused():
    """fluid: "HBK_ERR_INVALID_ARGUMENT (other grid, textures or capacity)": 125 particles
    into max_particles = 100."""
    h = FLUID.fresh(dict(FLUID.params, max_particles=100))
    before = bytes(h.save_state())
    refused(h, states(FLUID).a, {errors.InvalidArgument})
    assert bytes(h.save_state()) == before


COMPATIBLE = [
    # snow: "the other params may differ" (only flake_count, texture, contact_mode matter).
    (SNOW, dict(SNOW.params, temperature=-5.0, flake_radius=0.01)),
    (SNOW, dict(SNOW.params, volume_min=(0, 0, 0.2), volume_max=(0.5, 0.5, 0.6))),  # flakes out
    (RAIN, dict(RAIN.params, wiper_count=0)),  # particles and no wiper
    (RAIN, dict(RAIN.params, map_width=32, map_height=24)),
    (WATER, dict(WATER.params, cell_size=0.5, substeps=1)),
    (FLUID, dict(FLUID.params, max_particles=1000)),  # count within the capacity
    (FLUID, dict(FLUID.params, source="VELOCITY_GRID")),  # not in the header: loads
]


@pytest.mark.parametrize("e,params", COMPATIBLE,
                         ids=[f"{e.name}-{k}" for e, p in COMPATIBLE
                              for k in [next(k for k in p if p[k] != e.params.get(k))]])
def test_a_state_of_other_compatible_params_loads_and_steps(e, params):
    h = e.fresh(params)
    h.load_state(states(e).a)
    e.advance(h)
    assert all_finite(e.outputs(h))
    h.close()


# --- known bugs, each in a child process (a crash there fails the case, not the run) -------

CHILD = """
import json, sys
sys.path[:0] = json.loads(sys.argv[1])
import test_state_corruption as T
print("RESULT " + json.dumps(T.child_case(*json.loads(sys.argv[2]))))
"""


def child_case(name, pokes, steps):
    """In the child: A with `pokes` ([section or null, offset, format, value]) loaded into a
    fresh handle and stepped. Returns what happened; a crash never returns."""
    e = {x.name: x for x in EFFECTS}[name]
    a = states(e).a
    secs = {x.name: x for x in e.sections(a)}
    for section, off, fmt, value in pokes:
        a = poke(a, (secs[section].off if section else 0) + off, fmt, value)
    h = e.fresh()
    try:
        h.load_state(a)
    except errors.HydrobakeError as exc:
        return {"refused": type(exc).__name__}
    finite = [all_finite(e.outputs(h))]
    for _ in range(steps):
        e.advance(h)
        finite.append(all_finite(e.outputs(h)))
    out = {"loaded": True, "finite": finite}
    if e is SNOW:
        out["stats"] = h.stats()
    return out


def run_child(name, pokes, steps=3):
    proc = subprocess.run(
        [sys.executable, "-c", CHILD, json.dumps([HERE, ADDON]),
         json.dumps([name, pokes, steps])], capture_output=True, text=True, timeout=300,
        env=os.environ.copy())
    lines = [x for x in proc.stdout.splitlines() if x.startswith("RESULT ")]
    tail = "\n".join(proc.stderr.strip().splitlines()[-6:])
    assert proc.returncode == 0 and lines, f"child exit {proc.returncode}:\n{tail}"
    return json.loads(lines[-1][7:])


def refused_or_finite(res, code="FormatError"):
    assert res.get("refused", code) == code, res
    assert all(res.get("finite", [True])), f"loaded, then non-finite outputs: {res}"


INF = float("inf")


# Fixed bugs, kept as regressions. A rain drop of infinite (or >= FLT_MAX) mass made an
# infinite radius and the next step died with SIGFPE (grid_drops.c `d->moves % every`); from
# ~1e30 mg the radius overflowed int32_t (UBSan). A NaN time, wiper or particle position made
# rain_particles_repel overflow a bin index; a drop's shape offset of -1e10 radii overflowed
# add_ball's; a snow counter near INT64_MAX overflowed on the next step.
@pytest.mark.parametrize("pokes", [
    pytest.param([["drops", DROP * 3 + DROP_MASS, "d", INF]], id="drop-mass-inf"),
    pytest.param([["drops", DROP * 5 + DROP_MASS, "d", 1e300]], id="drop-mass-1e300"),
    pytest.param([["film", 8 * i, "d", 1e300] for i in range(32 * 24)], id="film-1e300"),
    # Finite: was undefined behaviour that only the sanitized build saw.
    pytest.param([["drops", DROP * 3 + DROP_MASS, "d", 1e30]], id="drop-mass-1e30"),
])
def test_rain_state_with_a_huge_drop_is_refused_or_steps(pokes):
    refused_or_finite(run_child("rain", pokes))


@pytest.mark.parametrize("pokes", [
    [[None, 64, "d", float("nan")]],
    [[None, 64, "d", INF]],
    [[None, 64, "d", 1e308]],
    [[None, 112, "f", float("nan")]],
    [["particles", PARTICLE_X, "f", float("nan")]],
    [["particles", PARTICLE + PARTICLE_Y, "f", float("nan")]],
], ids=["time-nan", "time-inf", "time-1e308", "wiper_value-nan", "particle-x-nan",
        "particle-y-nan"])
def test_rain_state_with_a_non_finite_wiper_or_particle_is_refused_or_steps(pokes):
    refused_or_finite(run_child("rain", pokes, steps=1))


@pytest.mark.parametrize("value", [-INF, -1e10])
def test_rain_state_with_an_absurd_drop_shape_is_refused_or_renders(value):
    refused_or_finite(run_child("rain", [["drops", DROP * 2 + DROP_OFF + 4, "f", value]],
                                steps=1))


@pytest.mark.parametrize("field", ["substeps", "flake_steps", "hits"])
def test_snow_state_with_a_huge_counter_is_refused_or_counts_on(field):
    f = next(f for f in SNOW.fields(b"") if f.name == "stats." + field)
    res = run_child("snow", [[None, f.off, "q", INT64_MAX]], steps=1)
    refused_or_finite(res)
    if "stats" in res:
        assert all(v >= 0 for v in res["stats"].values()), res
