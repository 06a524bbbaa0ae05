"""Solid fluid texturing: a fluid (built-in SPH, a particle system's particles, or a velocity
grid such as a Mantaflow cache) carries uvw and blend-weight volumes; each frame is baked as
an OpenVDB file and the textured surface mesh.

Inputs:
    fill         (lo, hi): particles filling a box at rest (SIMULATE)
    fill_shape   one obstacle-like entry (a sphere, box, turned box or mesh with its field):
                 particles filling that shape at rest instead of ``fill``'s box (SIMULATE)
    fill_velocity (vx, vy, vz) m/s: the velocity the filled particles start with (default 0)
    inflow       {frame: shape or None}: water poured in from that frame's step on (SIMULATE):
                 a shape as ``fill_shape`` takes it, None for none; the latest frame given at
                 or before a step's frame holds (a tap turned on and off, moved or reshaped);
                 or a list of such, one per tap (several inflows: then inflow_velocity and
                 inflow_normal may be lists too, one entry per tap, else one for all)
    inflow_velocity (vx, vy, vz) m/s: the velocity the inflow's water leaves at (default 0),
                 or {frame: (vx, vy, vz)}: the latest frame given at or before a step's frame
                 holds, the first before it (a hose that turns) (the inflow's lattice points
                 are jittered by ``jitter``, as the fill's)
    inflow_normal m/s (0..1000, default 0): speed added along the inflow shape's outward
                 normal, as Blender's Normal initial velocity; above 0 the inflow pours from
                 points on its surface, where that velocity leaves it (a sprinkler); or
                 {frame: m/s}, held as inflow_velocity's (a sprinkler turned up)
    outflow      {frame: shape or None}: a drain from that frame's step on (SIMULATE): the
                 water inside the shape goes; given as ``inflow`` is (a list: several drains)
    obstacles    [("sphere"|"box", centre, size) | ("turned_box", centre, half_sizes, (w, x, y,
                 z)) | ("mesh", centre, half_sizes, (w, x, y, z), field)] (SIMULATE): as they
                 are at the first frame (fluid.obstacle_list)
    obstacle_path {frame: obstacles}: where the obstacles are at the frames they move to (the
                 same count and kinds; a mesh's field None keeps its shape, one given is its
                 shape from that frame: a mesh that deforms); each frame's
                 step carries them from the frame before's
                 place (the latest given, else ``obstacles``) to its own
    particles    {frame: (positions (N, 3), velocities (N, 3))} (PARTICLES)
    velocity     {frame: (V_m (nz+1, ny+1, nx+1, 3), surface field or None)} (VELOCITY_GRID)
    paint        {frame: [(texture, centre, radius, falloff)]}: local paint strokes, laid
                 before the frame's step
    paint_points {frame: [(texture, positions (N, 3), coverage (N,) or None, radius,
                 falloff)]}: local paint from points (a surface painted at that frame), laid
                 after the frame's step
    rules        [(texture, lo[6], hi[6])]: feature paint (one bound per feature)
    voxel_textures {texture: (X, Y, Z, 3) tile}: voxel solid textures, sampled at every
                 surface vertex's advected uvw (see solid_textures)

Streams per frame:
    fluid_####.vdb    density (float), velocity (vec3, contravariant-relative), uvw and
                      uvw_b (vec3, invariant), blend_0..blend_{k-1} (float); the cross-fade
                      weight of uvw in the grid metadata "uvw_weight" (the frame's) and as a
                      grid "uvw_weight" (for volume shaders: constant, or per voxel with the
                      setting stretch_fade); uvw_unwrapped and uvw_b_unwrapped (vec3,
                      invariant): the fields moved by whole tiles to near the rest mapping,
                      for renderers (they interpolate without the wrap flags). All but
                      density and velocity hold values where the density is above 0 and are
                      zero (inactive) elsewhere; everywhere if there is no density at all
    surface_####.npz  positions, normals, triangles, uvw_a, uvw_b, blend, features,
                      uvw_weight, and sample_k (RGB) for each voxel texture k
"""
import bisect
import os

import numpy as np

from .. import args, arrays, errors, solid_textures
from ..fluid import Fluid, OBSTACLE_KINDS, obstacle_list
from . import register
from .base import Effect, plain
from .fluid_flows import Inflows, Outflows


def _digested(ob):
    """An obstacle as given, a mesh's field as its digest (a manifest lists the rest)."""
    if ob[0] == "mesh":
        return list(ob[:4]) + [arrays.digest(ob[4])]
    return ob


@register
class FluidEffect(Effect):
    name = "fluid"
    streams = ("fluid", "surface")
    detached_outputs = True  # every volume, mesh and state comes out in arrays of its own

    @classmethod
    def groups(cls):
        return {"fluid": Fluid.spec()}

    def __init__(self, params=None, inputs=None):
        super().__init__(params, inputs)
        self.fluid = Fluid(self.params_dict()["fluid"])
        inp = self.inputs
        try:
            if inp.get("obstacles"):
                self.fluid.set_obstacles(inp["obstacles"])
            if inp.get("fill_shape") is not None:
                self.fluid.fill_shape(inp["fill_shape"], float(inp.get("jitter", 0.0)))
                if self.fluid.particle_count == 0:  # a bake of nothing
                    raise errors.InvalidArgument(
                        "fill_shape: no particle fits inside it, within the box and clear of "
                        "the obstacles (is it thinner than particle_spacing, or outside?)")
            elif inp.get("fill") is not None:
                lo, hi = inp["fill"]
                self.fluid.fill_box(lo, hi, float(inp.get("jitter", 0.0)))
            if inp.get("fill_velocity") is not None:
                v = tuple(args.numbers(inp["fill_velocity"], "fill_velocity", 3))
                if not all(abs(c) <= 1000.0 for c in v):
                    raise errors.InvalidArgument(
                        f"fill_velocity = ({', '.join(f'{c:g}' for c in v)}): each component "
                        "must be a finite number in [-1000, 1000] m/s")
                pos, vel = self.fluid.particles()
                vel[:] = v
                self.fluid.set_particles(pos, vel)
            self.fluid.update_fields()
            for texture, lo, hi in inp.get("rules") or []:
                self.fluid.set_feature_rule(texture, lo, hi)
            self._check_inflow(inp)
            self._check_outflow(inp)
            self.path = self._path(inp.get("obstacles") or [], inp.get("obstacle_path") or {})
        except BaseException:
            self.fluid.close()
            raise
        self._path_keys = sorted(self.path)
        self.particles = inp.get("particles") or {}
        self.velocity = inp.get("velocity") or {}
        self.paint = inp.get("paint") or {}
        self.paint_points = inp.get("paint_points") or {}
        self.voxel_textures = inp.get("voxel_textures") or {}
        p = self.params["fluid"]
        lo, hi = np.array(p.box_min[:]), np.array(p.box_max[:])
        self.cell = (hi - lo) / np.array(p.resolution[:])
        self.origin = lo

    @staticmethod
    def _path(first, path):
        """{frame: checked obstacles} of the obstacle path: as many as ``obstacles``, of the
        same kinds (each frame's step moves them, it cannot add or change one)."""
        kinds = [ob[0] for ob in obstacle_list(first, "obstacles")]
        out = {}
        for f, obs in path.items():
            name = f"obstacle_path[{f}]"
            obs = obstacle_list(obs, name, fields=False)
            if [ob[0] for ob in obs] != kinds:
                raise errors.InvalidArgument(
                    f"{name}: kinds {[ob[0] for ob in obs]} must be the obstacles' {kinds} "
                    "(the same obstacles, moved)")
            out[int(f)] = obs
        return out

    def _check_inflow(self, inp):
        """The inflow inputs (fluid_flows.Inflows), checked whole before the first frame."""
        self.inflows = Inflows(inp, self.fluid, self.params["fluid"].source == 0,
                               float(inp.get("jitter", 0.0)))
        self._capped_at = None  # the first frame the inflow stopped at max_particles

    def _check_outflow(self, inp):
        """The outflow input (fluid_flows.Outflows), checked before the first frame."""
        self.outflows = Outflows(inp, self.fluid, self.params["fluid"].source == 0)

    def _obstacles_at(self, frame):
        """The obstacles where the path has them at ``frame``."""
        i = bisect.bisect_right(self._path_keys, frame)
        return self.path[self._path_keys[i - 1]] if i else self.inputs.get("obstacles") or []

    def scalar_inputs(self):
        """The filled box, its jitter and the obstacles (the SPH's start); and, when there
        are any, the feature rules, the paint strokes (a digest of a point stroke's arrays)
        and the voxel textures (a digest of each): a resume must not continue a bake with
        rules or paint other than its frames and checkpoints were made with (its checkpoint
        would even bring back the old rules), nor sample another texture from then on."""
        inp = self.inputs
        out = {"fill": inp.get("fill"), "jitter": float(inp.get("jitter", 0.0)),
               **({"fill velocity": [float(c) for c in inp["fill_velocity"]]}
                  if inp.get("fill_velocity") is not None else {}),
               **({"fill shape": _digested(inp["fill_shape"])}
                  if inp.get("fill_shape") is not None else {}),
               **self.inflows.scalar_inputs(),
               "obstacles": [_digested(ob) for ob in inp.get("obstacles") or []]}
        if inp.get("rules"):
            out["rules"] = [[int(t), [float(v) for v in lo], [float(v) for v in hi]]
                            for t, lo, hi in inp["rules"]]
        if self.paint:
            out["paint"] = {int(f): [[int(t), [float(c) for c in centre], float(r),
                                      float(fall)] for t, centre, r, fall in strokes]
                            for f, strokes in sorted(self.paint.items())}
        if self.paint_points:
            out["paint_points"] = {
                int(f): [[int(t), arrays.digest(pos, cov), float(r), float(fall)]
                         for t, pos, cov, r, fall in strokes]
                for f, strokes in sorted(self.paint_points.items())}
        if self.voxel_textures:
            out["voxel_textures"] = {int(k): arrays.digest(tex)
                                     for k, tex in sorted(self.voxel_textures.items())}
        return plain(out)

    def frame_inputs(self, frame):
        """The particles (PARTICLES) or the velocity cache (VELOCITY_GRID) set at ``frame``,
        and where moving obstacles are then."""
        source = getattr(self.velocity, "digest", None)  # (a cache: its file's bytes)
        if source is not None:
            out = {"particles": arrays.digest(None), "velocity": source(frame)}
        else:
            out = {"particles": arrays.digest(*self.particles.get(frame, (None, None))),
                   "velocity": arrays.digest(*self.velocity.get(frame, (None, None)))}
        # the shapes this frame's step pours from and drains into (a resume must match them)
        out.update(self.inflows.frame_inputs(frame))
        out.update(self.outflows.frame_inputs(frame))
        if self.path:
            obs = self._obstacles_at(frame)
            turned = any(ob[0] in ("turned_box", "mesh") for ob in obs)  # (else as before)
            # (and the fields of meshes that deform: their shapes here)
            shapes = [ob[4] for ob in obs if ob[0] == "mesh" and ob[4] is not None]
            out["obstacles"] = arrays.digest(
                np.array([OBSTACLE_KINDS.index(ob[0]) for ob in obs], np.int64),
                np.array([list(c) + ([e, 0.0, 0.0] if k == "sphere" else list(e)) +
                          (list(rot[0]) if rot else [0.0] * 4 if turned else [])
                          for k, c, e, *rot in obs], np.float32).reshape(-1, 10 if turned else 6),
                *shapes)
        return out

    def step(self, frame, progress):
        if frame in self.particles:
            pos, vel = self.particles[frame]
            self.fluid.set_particles(pos, vel)
        if frame in self.velocity:
            vel, surf = self.velocity[frame]
            self.fluid.set_velocity_grid(vel, surf)
        for texture, centre, radius, falloff in self.paint.get(frame, []):
            self.fluid.paint_sphere(texture, centre, radius, falloff)
        if self.path:
            self.fluid.move_obstacles(self._obstacles_at(frame))
        self.inflows.apply(frame)
        self.outflows.apply(frame)
        self.fluid.step(progress)
        if self._capped_at is None and self.fluid.inflow_added[1]:
            self._capped_at = frame
        # Points are painted on the frame's own surface (as the artist saw it), so they land
        # after its step.
        for texture, positions, coverage, radius, falloff in self.paint_points.get(frame, []):
            self.fluid.paint_points(texture, positions, coverage, radius, falloff)
        self.mesh = self.fluid.surface(progress)

    def forecast(self, start, end):
        """An inflow fills the fluid: the frame it will reach max_particles at, if within the
        bake and before an outflow opens, from the particles it starts with, its shape's
        filling as it is turned on and the rate it pours at each frame after (its columns
        along the flow, each pouring once the water before has gone a spacing:
        hbk_fluid_inflow_rate). The rate leaves out water backing up to the tap (it pours
        less) and a jet's own pressure (a slow one pours more: 15% at 0.5 m/s)."""
        if not self.inflows.any:
            return []
        fp = self.params["fluid"]
        count, at, rate = float(self.fluid.particle_count), None, 0.0
        on, opened = set(), None  # (the taps that poured the frame before; an outflow opens)
        try:
            for frame in range(start, end + 1):
                if self.outflows.opened(frame):
                    opened = frame  # (from here on it drains: how much, only the bake tells)
                    break
                pouring = self.inflows.alone(frame)
                for tap, (_rate, points) in pouring:
                    if tap not in on:  # turned on: its shape fills at once, then its stream
                        count += points
                on = {tap for tap, _ in pouring}
                now = sum(r for _, (r, _points) in pouring)
                count += now * fp.dt
                if at is None and count > fp.max_particles:
                    at, rate = frame, now
        finally:
            self.inflows.forget()  # (step sets its own)
        if at is None:
            return []
        need = int(-(-count // 1000) * 1000)  # (up to a thousand)
        until, drain = (("to the end", "") if opened is None else
                        (f"until the outflow opens at frame {opened}", " sooner"))
        return [f"the inflow will stop pouring at about frame {at} of {start}-{end}: pouring "
                f"about {rate:.0f} particles a second onto the {self.fluid.particle_count} the "
                f"fluid starts with, it reaches max_particles = {fp.max_particles} there; to "
                f"pour {until}, raise it to about {need}, or add an outflow to drain the "
                f"water{drain}"]

    def notes(self):
        if self._capped_at is None:
            return []
        return [f"the inflow stopped pouring at frame {self._capped_at}: the fluid holds "
                f"max_particles = {self.params['fluid'].max_particles} particles; raise it "
                "for more water"]

    def outputs(self, frame):
        threads = int(self.params["fluid"].threads) or (os.cpu_count() or 1)

        def xyz(a):  # (nz, ny, nx, c) -> pyopenvdb's [x, y, z(, c)]
            a = arrays.grid_to_xyz(a, threads)
            return a[..., 0] if a.shape[3] == 1 else a
        common = dict(voxel_size=tuple(self.cell), origin=tuple(self.origin))
        weight = float(self.fluid.uvw_weight())
        density = self.fluid.volume("density")
        # The texturing grids hold values where there is fluid (density > 0) and are zero, so
        # inactive, elsewhere: dense over the whole box they were most of each file and of its
        # writing time, for voxels nothing renders. (A velocity grid given without a surface
        # field has no density: then everywhere.)
        dry = density[..., 0] <= 0.0
        if dry.all():
            dry[...] = False

        def wet(name):
            a = self.fluid.volume(name)
            np.copyto(a, 0.0, where=dry[..., None])  # 5x faster than a[dry] = 0
            return xyz(a)
        grids = [dict(name="density", array=xyz(density), **common),
                 dict(name="velocity", array=xyz(self.fluid.volume("motion")),
                      vector_type="CONTRAVARIANT_RELATIVE", **common),
                 dict(name="uvw", array=wet("uvw_a"), vector_type="INVARIANT",
                      metadata={"uvw_weight": weight}, **common),
                 dict(name="uvw_b", array=wet("uvw_b"), vector_type="INVARIANT", **common),
                 # For renderers, which interpolate without the wrap flags: the same fields
                 # unwrapped near the rest mapping, so plain trilinear interpolation is right
                 # (no line at each 1 -> 0 wrap) and even a texture that does not repeat
                 # shows no tile seams where the fluid moved less than half a tile.
                 dict(name="uvw_unwrapped", array=wet("uvw_a_unwrapped"),
                      vector_type="INVARIANT", **common),
                 dict(name="uvw_b_unwrapped", array=wet("uvw_b_unwrapped"),
                      vector_type="INVARIANT", **common),
                 # The cross-fade weight of uvw A as a grid, for volume shaders: the frame's
                 # weight, or per voxel with stretch_fade.
                 dict(name="uvw_weight", array=wet("uvw_weight"), **common)]
        blend = wet("blend")
        if blend.ndim == 3:
            blend = blend[..., None]
        grids += [dict(name=f"blend_{k}", array=np.ascontiguousarray(blend[..., k]), **common)
                  for k in range(blend.shape[3])]
        # The mesh carries the cross-fade weight of uvw A per vertex (an attribute for shaders).
        mesh = dict(self.mesh)
        scales = self.params["fluid"].texture_scale
        for k, tex in sorted(self.voxel_textures.items()):
            mesh[f"sample_{k}"] = solid_textures.surface_colour(
                tex, float(scales[k]), mesh["uvw_a"], mesh["uvw_b"], mesh["uvw_weight"])
        return {"fluid": ("vdb", grids, {}), "surface": ("npz", mesh, {})}

    def save_state(self):
        return self.fluid.save_state()

    def load_state(self, data):
        self.fluid.load_state(data)

    def close(self):
        self.fluid.close()


