"""Solid fluid texturing (hbk_fluid_*): an SPH fluid (or caller-set particles or velocity
grid) carrying uvw, blend-weight and wrap-flag volumes, and the metaball surface with per-vertex
attributes. Vertex fields are (nz+1, ny+1, nx+1, c) arrays here (numpy's C order of the
library's x-fastest layout)."""
import ctypes

import numpy as np

from . import _lib, args, arrays, errors
from ._lib import Message, P, Progress, check_message
from .handle import Handle

FEATURES = ("density", "density_rate", "flow_angle", "acceleration", "divergence",
            "curvature")
VOLUMES = {"uvw_a": (0, 3), "uvw_b": (1, 3), "blend": (2, None), "motion": (3, 3),
           "density": (4, 1), "surface": (5, 1), "features": (6, len(FEATURES)),
           "wrap_a": (7, 3), "wrap_b": (8, 3), "uvw_weight": (9, 1),
           "uvw_a_unwrapped": (10, 3), "uvw_b_unwrapped": (11, 3)}
OBSTACLE_KINDS = ("sphere", "box", "turned_box", "mesh")  # hbk_fluid_obstacle_t.type 0..3
FIELD_MAX_DIM = 128  # HBK_FLUID_FIELD_MAX_DIM: a mesh field's points per axis
# hbk_noise3d_tileable's range of size (checked here too: the output is allocated from it).
NOISE_MAX_SIZE = 1024


class Obstacle(ctypes.Structure):
    _fields_ = [("type", ctypes.c_int32), ("center", ctypes.c_float * 3),
                ("extent", ctypes.c_float * 3), ("rotation", ctypes.c_float * 4)]


_lib.check_mirror(Obstacle, "hbk_fluid_obstacle_t")
_f32 = arrays.float_array
_V3 = ctypes.c_float * 3
Handle.declare("fluid", [
    ("set_particles", [_f32, ctypes.c_void_p, ctypes.c_int32]),
    ("fill_box", [P(_V3), P(_V3), ctypes.c_float]),
    ("fill_shape", [P(Obstacle), ctypes.c_void_p, ctypes.c_void_p, ctypes.c_float]),
    ("set_inflow_normal", [ctypes.c_void_p, ctypes.c_void_p, ctypes.c_void_p, P(_V3),
                           ctypes.c_float, ctypes.c_float]),
    ("add_inflow", [ctypes.c_void_p, ctypes.c_void_p, ctypes.c_void_p, P(_V3), ctypes.c_float]),
    ("set_outflow", [ctypes.c_void_p, ctypes.c_void_p, ctypes.c_void_p]),
    ("add_outflow", [ctypes.c_void_p, ctypes.c_void_p, ctypes.c_void_p]),
    ("get_particles", [ctypes.c_void_p, ctypes.c_void_p, ctypes.c_int32]),
    ("set_obstacles", [P(Obstacle), ctypes.c_int32]),
    ("move_obstacles", [P(Obstacle), ctypes.c_int32]),
    ("set_obstacle_field", [ctypes.c_int32, P(ctypes.c_int32 * 3), _f32]),
    ("move_obstacle_field", [ctypes.c_int32, P(ctypes.c_int32 * 3), _f32]),
    ("set_velocity_grid", [_f32, ctypes.c_void_p]),
    ("step", [P(Progress)]), ("update_fields", []),
    ("get_volume", [ctypes.c_int32, _f32, ctypes.c_size_t]),
    ("sample_uvw", [ctypes.c_int32, P(_V3), P(_V3)]),
    ("paint_mask", [ctypes.c_int32, _f32]),
    ("paint_sphere", [ctypes.c_int32, P(_V3), ctypes.c_float, ctypes.c_float]),
    ("paint_points", [ctypes.c_int32, ctypes.c_int32, ctypes.c_void_p, ctypes.c_void_p,
                      ctypes.c_float, ctypes.c_float]),
    ("clear_paint", []),
    ("set_feature_rule", [ctypes.c_int32, P(ctypes.c_float * len(FEATURES)),
                          P(ctypes.c_float * len(FEATURES))]),
    ("capture_feature_rule", [ctypes.c_int32, _f32]),
    ("clear_feature_rule", [ctypes.c_int32]),
    ("update_surface", [P(Progress)]),
    ("mesh_counts", [P(ctypes.c_int32), P(ctypes.c_int32)]),
    ("get_mesh", [ctypes.c_void_p] * 7),
    ("get_mesh_weight", [ctypes.c_void_p]),
])
_lib.declare([
    ("hbk_fluid_particle_count", ctypes.c_int32, [ctypes.c_void_p]),
    ("hbk_fluid_substeps_taken", ctypes.c_int32, [ctypes.c_void_p]),
    ("hbk_fluid_inflow_added", ctypes.c_int32, [ctypes.c_void_p, P(ctypes.c_int32)]),
    ("hbk_fluid_inflow_points", ctypes.c_int32, [ctypes.c_void_p]),
    ("hbk_fluid_inflow_rate", ctypes.c_double, [ctypes.c_void_p]),
    ("hbk_fluid_outflow_removed", ctypes.c_int32, [ctypes.c_void_p]),
    ("hbk_fluid_grid_vertices", ctypes.c_size_t, [ctypes.c_void_p, P(ctypes.c_int32 * 3)]),
    ("hbk_fluid_volume_size", ctypes.c_size_t, [ctypes.c_void_p, ctypes.c_int32]),
    ("hbk_fluid_uvw_weight", ctypes.c_float, [ctypes.c_void_p]),
    ("hbk_noise3d_tileable", _lib.hbk_result_t,
     [_f32, ctypes.c_int32, ctypes.c_int32, ctypes.c_int32, ctypes.c_float, ctypes.c_uint64,
      P(Message)], check_message),
])


_SHAPES = {"sphere": (3, "values (kind, centre, size)"),
           "box": (3, "values (kind, centre, size)"),
           "turned_box": (4, "values (kind, centre, half_sizes, rotation)"),
           "mesh": (5, "values (kind, centre, half_sizes, rotation, field)")}


def obstacle_list(obstacles, what, fields=True, one=False):
    """[(kind, centre (3 floats), size (radius, or 3 half-sizes)[, rotation[, field]])] of
    obstacles given as ("sphere", centre, radius), ("box", centre, half_sizes), ("turned_box",
    centre, half_sizes, rotation): a box turned by the unit quaternion (w, x, y, z), its
    half-sizes along its own axes, or ("mesh", centre, half_sizes, rotation, field): a turned
    box holding a mesh, field its signed distances (m, negative inside) at (nz, ny, nx) points
    spanning the box, corners included (2..128 a side; pad the box so the mesh is at least
    half a particle spacing inside it). Each checked by name. With ``fields`` False (a move) a
    mesh's field may be None: it keeps the one it has. With ``one``, ``obstacles`` is a single
    entry, named ``what``."""
    out = []
    entries = [obstacles] if one else args.sequence(obstacles, what, what="obstacles")
    for i, ob in enumerate(entries):
        name = what if one else f"{what}[{i}]"
        items = args.sequence(ob, name, what="values (kind, centre, size[, rotation])")
        # Checked by name: any other kind would be taken as a box (type 1).
        kind = args.choice(items[0] if items else None, f"{name}.kind", OBSTACLE_KINDS)
        items = args.sequence(ob, name, *_SHAPES[kind])
        if kind == "sphere":
            size = args.number(items[2], f"{name}.radius")
        else:
            size = tuple(args.numbers(items[2], f"{name}.half_sizes", 3))
        entry = (kind, tuple(args.numbers(items[1], f"{name}.centre", 3)), size)
        if kind in ("turned_box", "mesh"):
            rot = tuple(args.numbers(items[3], f"{name}.rotation", 4))
            length = float(np.sqrt(np.sum(np.square(rot, dtype=np.float64))))
            if not abs(length - 1.0) <= 1e-3:  # (as the library checks, with this name)
                raise errors.InvalidArgument(
                    f"{name}.rotation: length {length:.6g}, must be a unit quaternion (w, x, y, "
                    "z), length 1 +- 1e-3")
            entry += (rot,)
        if kind == "mesh":
            entry += (_field(items[4], f"{name}.field", fields),)
        out.append(entry)
    return out


def _field(value, name, required):
    """A mesh's distance field as a (nz, ny, nx) float32 array, checked; None where a move
    leaves it out."""
    if value is None and not required:
        return None
    f = args.float32_array(value, name)
    if f.ndim != 3 or not all(2 <= n <= FIELD_MAX_DIM for n in f.shape):
        raise errors.InvalidArgument(f"{name}: shape {f.shape}: must be (nz, ny, nx), each in "
                                     f"[2, {FIELD_MAX_DIM}]")
    bad = ~(np.abs(f) <= 1e6)
    if bad.any():
        at = tuple(int(i) for i in np.argwhere(bad)[0])
        raise errors.InvalidArgument(f"{name}{list(at)} = {f[at]}: must be a finite distance in "
                                     "[-1e6, 1e6] m")
    return f


def _obstacles(obstacles, what, fields=True, one=False):
    """(hbk_fluid_obstacle_t array, count, the checked list) of obstacle_list's entries."""
    obstacles = obstacle_list(obstacles, what, fields, one)
    arr = (Obstacle * max(len(obstacles), 1))()
    for i, (kind, c, e, *rot) in enumerate(obstacles):
        ext = _V3(e, 0.0, 0.0) if kind == "sphere" else _V3(*e)
        arr[i] = Obstacle(OBSTACLE_KINDS.index(kind), _V3(*c), ext,
                          (ctypes.c_float * 4)(*(rot[0] if rot else (0.0,) * 4)))
    return arr, len(obstacles), obstacles


def _shape(shape):
    """One obstacle-like entry, checked as "shape", as fill_shape, set_inflow and set_outflow
    take it: the record, its field's dims and its distances (both None but for a mesh), each
    an object a void pointer argument takes (and that keeps its memory alive for the call)."""
    arr, _, (checked,) = _obstacles(shape, "shape", one=True)
    if checked[0] != "mesh":
        return arr, None, None
    field = checked[4]
    return arr, (ctypes.c_int32 * 3)(*field.shape[::-1]), field.ctypes


class Fluid(Handle):
    prefix = "fluid"

    @property
    def vertices(self):
        """(nx+1, ny+1, nz+1)."""
        v = (ctypes.c_int32 * 3)()
        _lib.lib.hbk_fluid_grid_vertices(self.h, ctypes.byref(v))
        return tuple(v)

    def set_particles(self, pos, vel=None):
        pos = args.float32_array(pos, "pos", 3)
        v = None if vel is None else args.float32_array(vel, "vel", 3)
        if v is not None and v.shape != pos.shape:
            raise errors.InvalidArgument(f"vel: shape {v.shape} must match pos {pos.shape}")
        self.call("set_particles", pos.reshape(-1), None if v is None else v.ctypes.data,
                  len(pos))

    def fill_box(self, lo, hi, jitter=0.0):
        self.call("fill_box", args.numbers(lo, "lo", 3), args.numbers(hi, "hi", 3),
                  args.number(jitter, "jitter"))

    def fill_shape(self, shape, jitter=0.0):
        """Particles at rest on fill_box's lattice inside ``shape``, one entry as
        set_obstacles takes them (a sphere, a box, a turned box, or a mesh with its field),
        clear of the obstacles: water poured in that shape (it is not kept as an obstacle)."""
        arr, dims, field = _shape(shape)
        self.call("fill_shape", arr, dims, field, args.number(jitter, "jitter"))

    def set_inflow(self, shape, velocity=(0.0, 0.0, 0.0), jitter=0.0, normal=0.0):
        """Water poured in from ``shape`` (one entry as fill_shape takes it) at ``velocity``
        (m/s) from the next step on: at every SPH substep, each point of a lattice inside it
        (laid along the flow, so a tilted tap pours as much as a straight one) with no
        particle nearer than a spacing gains one moving at ``velocity``,
        until max_particles. With ``normal`` > 0 (m/s along the shape's outward normal, as
        Blender's Normal initial velocity) it is a sprinkler: its points lie on the surface,
        a spacing apart, each pouring at ``velocity`` + normal x its normal where that leaves
        the shape. None stops it. Not in the saved state: set it again after load_state."""
        if shape is None:
            self.call("set_inflow_normal", None, None, None, _V3(0.0, 0.0, 0.0), 0.0, 0.0)
            return
        arr, dims, field = _shape(shape)
        self.call("set_inflow_normal", ctypes.addressof(arr), dims, field,
                  args.numbers(velocity, "velocity", 3), args.number(normal, "normal"),
                  args.number(jitter, "jitter"))

    def add_inflow(self, shape, velocity=(0.0, 0.0, 0.0), normal=0.0):
        """A further inflow beside those set (two taps, a fountain's jets): ``shape`` pours
        at ``velocity`` (plus ``normal`` along its surface normal) exactly as set_inflow would
        pour it alone, with set_inflow's jitter (0 after set_inflow(None)); the points and the
        rates add up. set_inflow replaces them all."""
        arr, dims, field = _shape(shape)
        self.call("add_inflow", ctypes.addressof(arr), dims, field,
                  args.numbers(velocity, "velocity", 3), args.number(normal, "normal"))

    @property
    def inflow_points(self):
        """Points the inflow pours from: its lattice's, or a sprinkler's on its surface where
        its velocity leaves it (0: none, or a shape too thin or outside)."""
        return int(_lib.lib.hbk_fluid_inflow_points(self.h))

    @property
    def inflow_rate(self):
        """Particles a second the inflow pours while the water before clears it: its speed /
        particle_spacing x the lattice columns its points make along its velocity (a
        sprinkler's: each surface point a column at its own velocity; 0: none)."""
        return float(_lib.lib.hbk_fluid_inflow_rate(self.h))

    @property
    def inflow_added(self):
        """(particles the inflow added in the last step, whether it stopped at
        max_particles)."""
        capped = ctypes.c_int32()
        added = _lib.lib.hbk_fluid_inflow_added(self.h, ctypes.byref(capped))
        return int(added), bool(capped.value)

    def set_outflow(self, shape):
        """A drain: after every SPH substep the particles inside ``shape`` (one entry as
        fill_shape takes it) go, the others keeping their order. None stops it. Not in the
        saved state: set it again after load_state."""
        if shape is None:
            self.call("set_outflow", None, None, None)
            return
        arr, dims, field = _shape(shape)
        self.call("set_outflow", ctypes.addressof(arr), dims, field)

    def add_outflow(self, shape):
        """A further drain beside those set (a pool's two drains): the particles inside
        ``shape`` go too, after every SPH substep. set_outflow replaces them all."""
        arr, dims, field = _shape(shape)
        self.call("add_outflow", ctypes.addressof(arr), dims, field)

    @property
    def outflow_removed(self):
        """Particles the outflow took in the last step."""
        return int(_lib.lib.hbk_fluid_outflow_removed(self.h))

    @property
    def particle_count(self):
        return int(_lib.lib.hbk_fluid_particle_count(self.h))

    def particles(self):
        n = self.particle_count
        pos, vel = np.empty((n, 3), np.float32), np.empty((n, 3), np.float32)
        self.call("get_particles", pos.ctypes.data, vel.ctypes.data, n)
        return pos, vel

    def set_obstacles(self, obstacles):
        """obstacles: [("sphere", centre, radius) | ("box", centre, half_sizes) |
        ("turned_box", centre, half_sizes, (w, x, y, z)) | ("mesh", centre, half_sizes, (w, x,
        y, z), field)], still where they are (a move not stepped yet is dropped); see
        obstacle_list."""
        arr, n, checked = _obstacles(obstacles, "obstacles")
        self.call("set_obstacles", arr, n)
        self._set_fields(checked)

    def move_obstacles(self, to):
        """Where the obstacles are at the end of the next step (a list like set_obstacles',
        one per obstacle, in order, of the same kinds): the step carries them there in a
        straight line (a turned box turning at a constant rate, the shorter way) and the fluid
        meets them moving. A mesh's field None keeps its shape; a field given is its shape
        at the end of the step (a mesh that deforms): with the shape of the one it has, the
        step changes one into the other and the water meets the surface moving; another
        shape is taken at once."""
        arr, n, checked = _obstacles(to, "to", fields=False)
        self.call("move_obstacles", arr, n)
        self._set_fields(checked, "move_obstacle_field")

    def _set_fields(self, checked, how="set_obstacle_field"):
        for i, ob in enumerate(checked):
            if ob[0] == "mesh" and ob[4] is not None:
                self.call(how, i, (ctypes.c_int32 * 3)(*ob[4].shape[::-1]), ob[4].reshape(-1))

    def _per_vertex(self, name, values, components=1):
        """values as a flat float32 array of one entry per grid vertex (the C side reads that
        many, so a wrong size must stop here)."""
        a = args.float32_array(values, name).reshape(-1)
        want = components * int(np.prod(self.vertices))
        if a.size != want:
            raise errors.InvalidArgument(f"{name}: {a.size} values, must be {want} (grid "
                                         f"vertices {self.vertices} x {components})")
        return a

    def set_velocity_grid(self, velocity, surface=None):
        vel = self._per_vertex("velocity", velocity, 3)
        s = None if surface is None else self._per_vertex("surface", surface)
        self.call("set_velocity_grid", vel, None if s is None else s.ctypes.data)

    def step(self, progress=None):
        self.call("step", args.progress(progress))

    @property
    def substeps_taken(self):
        """SPH steps the last step took: at least `substeps`, more where stability needs."""
        return _lib.lib.hbk_fluid_substeps_taken(self.h)

    def update_fields(self):
        self.call("update_fields")

    def volume(self, name):
        """A volume as (nz, ny, nx, c) (vertex fields +1 per axis), x fastest in memory."""
        idx, _ = VOLUMES[args.choice(name, "name", VOLUMES)]
        n = _lib.lib.hbk_fluid_volume_size(self.h, idx)
        out = np.empty(n, np.float32)
        self.call("get_volume", idx, out, n)
        nx, ny, nz = self.vertices
        if name.startswith("wrap"):
            nx, ny, nz = nx - 1, ny - 1, nz - 1
        return out.reshape(nz, ny, nx, -1)

    def uvw_weight(self):
        return _lib.lib.hbk_fluid_uvw_weight(self.h)

    def paint_sphere(self, texture, center, radius, falloff=0.0):
        self.call("paint_sphere", args.integer(texture, "texture"),
                  args.numbers(center, "center", 3), args.number(radius, "radius"),
                  args.number(falloff, "falloff"))

    def paint_mask(self, texture, mask):
        self.call("paint_mask", args.integer(texture, "texture"), self._per_vertex("mask", mask))

    def paint_points(self, texture, positions, coverage=None, radius=0.0, falloff=0.0):
        """Paints texture around each point (n x 3, world space): coverage (n values in [0, 1],
        None: 1) within radius m, fading to 0 over falloff m; the largest coverage wins."""
        texture = args.integer(texture, "texture")
        pos = args.float32_array(positions, "positions", 3)
        cov = None if coverage is None else args.float32_array(coverage, "coverage").reshape(-1)
        if cov is not None and len(cov) != len(pos):
            raise errors.InvalidArgument(f"coverage: {len(cov)} values for {len(pos)} points")
        self.call("paint_points", texture, len(pos), pos.ctypes.data if len(pos) else None,
                  None if cov is None else cov.ctypes.data, args.number(radius, "radius"),
                  args.number(falloff, "falloff"))

    def set_feature_rule(self, texture, lo, hi):
        n = len(FEATURES)
        self.call("set_feature_rule", args.integer(texture, "texture"),
                  args.numbers(lo, "lo", n), args.numbers(hi, "hi", n))

    def capture_feature_rule(self, texture, mask):
        self.call("capture_feature_rule", args.integer(texture, "texture"),
                  self._per_vertex("mask", mask))

    def surface(self, progress=None):
        """The surface mesh: dict of positions, normals, triangles, uvw_a, uvw_b, blend,
        features and uvw_weight (A's cross-fade weight) per vertex."""
        self.call("update_surface", args.progress(progress))
        nv, nt = ctypes.c_int32(), ctypes.c_int32()
        self.call("mesh_counts", ctypes.byref(nv), ctypes.byref(nt))
        nv, nt = nv.value, nt.value
        k = self.params.textures
        m = {"positions": np.empty((nv, 3), np.float32), "normals": np.empty((nv, 3), np.float32),
             "triangles": np.empty((nt, 3), np.int32), "uvw_a": np.empty((nv, 3), np.float32),
             "uvw_b": np.empty((nv, 3), np.float32), "blend": np.empty((nv, k), np.float32),
             "features": np.empty((nv, len(FEATURES)), np.float32)}
        self.call("get_mesh", *(m[n].ctypes.data for n in (
            "positions", "normals", "triangles", "uvw_a", "uvw_b", "blend", "features")))
        m["uvw_weight"] = np.empty(nv, np.float32)
        self.call("get_mesh_weight", m["uvw_weight"].ctypes.data)
        return m



def noise3d(size, period=4, octaves=3, persistence=0.5, seed=0):
    """A tileable size^3 gradient-noise texture in [0, 1], as (z, y, x); size in [1, 1024]."""
    size = args.integer(size, "size", 1, NOISE_MAX_SIZE)
    out = np.empty(size ** 3, np.float32)
    _lib.lib.hbk_noise3d_tileable(out, size, args.integer(period, "period"),
                                  args.integer(octaves, "octaves"),
                                  args.number(persistence, "persistence"),
                                  args.integer(seed, "seed", 0, 2**64 - 1), Message())
    return out.reshape(size, size, size)
