"""The fluid effect's inflows and outflows and their schedules: each tap's shape by frame, its
velocity and Normal (for the bake or by frame), each drain's shape by frame, checked before
the first frame, set in the library as each frame's step needs them (set_inflow, then
add_inflow for the other taps; set_outflow and add_outflow alike), and what a resume compares
of them."""
import bisect

import numpy as np

from .. import args, arrays, errors
from ..fluid import OBSTACLE_KINDS, obstacle_list


def schedule(given, name):
    """{frame: checked shape or None} of an inflow or outflow input."""
    if not isinstance(given, dict):
        raise errors.InvalidArgument(f"{name}: {type(given).__name__}: must be a dict "
                                     "{frame: shape or None}")
    return {int(f): None if sh is None else obstacle_list(sh, f"{name}[{f}]", one=True)[0]
            for f, sh in given.items()}


def key_at(keys, frame):
    """The latest of the sorted frames ``keys`` at or before ``frame`` (None: none yet)."""
    i = bisect.bisect_right(keys, frame)
    return keys[i - 1] if i else None


def shape_digest(shape):
    """A digest of one shape (or None) as a resume compares it."""
    if shape is None:
        return arrays.digest(None)
    return arrays.digest(
        np.array([OBSTACLE_KINDS.index(shape[0])], np.int64),
        np.array(list(shape[1]) + list(np.ravel(shape[2])) +
                 (list(shape[3]) if len(shape) > 3 else []), np.float32),
        shape[4] if len(shape) > 4 else None)


def _named(name, frame, put):
    """put(), a refusal named "name[frame]" (the library's "name: " prefix dropped)."""
    try:
        put()
    except errors.InvalidArgument as exc:
        raise errors.InvalidArgument(
            f"{name}[{frame}]: {str(exc).removeprefix(f'{name}: ')}") from None


def _shapes_digest(shapes):
    """One digest of several shapes (or Nones), in order."""
    digests = "".join(shape_digest(sh) for sh in shapes)
    return arrays.digest(np.frombuffer(digests.encode(), np.uint8))


def _velocity(given, name):
    """A checked velocity (vx, vy, vz) m/s, each component within +-1000."""
    v = tuple(args.numbers(given, name, 3))
    if not all(abs(c) <= 1000.0 for c in v):
        raise errors.InvalidArgument(
            f"{name} = ({', '.join(f'{c:g}' for c in v)}): each component must be a finite "
            "number in [-1000, 1000] m/s")
    return v


def _speed(given, name):
    """A checked speed in m/s, within [0, 1000]."""
    v = args.number(given, name)
    if not 0.0 <= v <= 1000.0:
        raise errors.InvalidArgument(f"{name} = {v:g}: must be in [0, 1000] m/s")
    return v


class ByFrame:
    """An input given for the whole bake or as {frame: value}: the latest frame given at or
    before a frame holds, the first before it. ``values`` is {None: value} or {frame: value},
    each checked by check(value, name)."""

    def __init__(self, given, name, check, what):
        self.by_frame = isinstance(given, dict)
        self.values = ({int(f): check(v, f"{name}[{f}]") for f, v in given.items()}
                       if self.by_frame else {None: check(given, name)})
        if not self.values:
            raise errors.InvalidArgument(f"{name}: {{}}: must give {what} for at least one "
                                         "frame")
        self.keys = sorted(self.values) if self.by_frame else [None]

    def at(self, frame):
        key = key_at(self.keys, frame) if self.by_frame else None
        return self.values[self.keys[0] if key is None else key]


class _Inflow:
    """One tap: its shape by frame, its velocity and its Normal."""

    def __init__(self, shapes, velocity, normal, name, suffix):
        self.shapes = schedule(shapes, name)
        self.keys = sorted(self.shapes)
        self.velocity = ByFrame(velocity, f"inflow_velocity{suffix}", _velocity, "a velocity")
        self.normal = ByFrame(normal, f"inflow_normal{suffix}", _speed, "a speed")

    def at(self, frame):
        """(shape, velocity, normal) it pours with at ``frame``; shape None: it does not."""
        key = key_at(self.keys, frame)
        return (None if key is None else self.shapes[key], self.velocity.at(frame),
                self.normal.at(frame))

    def key(self, frame):
        """What tells its pouring at ``frame`` from another frame's (shapes by their frame)."""
        return (key_at(self.keys, frame), self.velocity.at(frame), self.normal.at(frame))

    def changes(self):
        """The frames its shape, velocity or normal changes at."""
        return (set(self.shapes) | set(self.velocity.keys) | set(self.normal.keys)) - {None}


def _per_inflow(given, count, name, vector):
    """``given`` for each of ``count`` inflows: a list of one per inflow (for a ``vector``,
    one whose items are not numbers: a velocity given as a list is one for all), else the
    same for all."""
    if isinstance(given, (list, tuple)) and (not vector or (
            given and not isinstance(given[0], (int, float)))):
        if len(given) != count:
            raise errors.InvalidArgument(f"{name}: {len(given)} entries for {count} inflows: "
                                         "must give one for each, or one for all")
        return list(given)
    return [given] * count


class Inflows:
    """The inflow inputs (``inflow`` one {frame: shape} or a list of them, one per tap;
    ``inflow_velocity`` and ``inflow_normal`` one for all or a list of one per tap), checked
    whole before the first frame: each shape by the library too, as it will be set at its
    frame alone and with the others, so that a shape it refuses (holding more particles than
    max_particles, say) stops the bake before it starts, not at that frame."""

    def __init__(self, inp, fluid, simulating, jitter):
        given = inp.get("inflow") or {}
        self.many = isinstance(given, list)  # (a tuple is a shape given bare: refused)
        shapes = list(given) if self.many else [given]
        vels = _per_inflow(inp.get("inflow_velocity", (0.0,) * 3), len(shapes),
                           "inflow_velocity", True)
        normals = _per_inflow(inp.get("inflow_normal", 0.0), len(shapes), "inflow_normal",
                              False)
        self.taps = [_Inflow(sh, v, n, f"inflow[{k}]" if self.many else "inflow",
                             f"[{k}]" if self.many else "")
                     for k, (sh, v, n) in enumerate(zip(shapes, vels, normals))]
        self.any = any(t.shapes for t in self.taps)
        self.fluid, self.jitter, self._on = fluid, jitter, None
        self._alone = {}  # (tap, key): (rate, points) of it alone (the forecast's)
        if self.any and not simulating:
            raise errors.InvalidArgument("inflow: only the simulation (source SIMULATE) "
                                         "pours an inflow")
        for k, tap in enumerate(self.taps):
            name = f"inflow[{k}]" if self.many else "inflow"
            points = 0
            for f in sorted(tap.changes()):  # (a velocity turned into a sprinkler: none left)
                shape, v, n = tap.at(f)
                if shape is not None:
                    _named(name, f, lambda: self._set(((shape, v, n),)))
                    points += self.fluid.inflow_points
            if any(sh is not None for sh in tap.shapes.values()) and points == 0:
                # (one frame's shape outside the box pours nothing there; every one is a
                # mistake)
                raise errors.InvalidArgument(
                    f"{name}: no particle fits inside its shape at any frame, within the box "
                    "(is it thinner than particle_spacing, or outside?)")
        if len(self.taps) > 1:  # together, where any changes
            for f in sorted(set().union(*(t.changes() for t in self.taps))):
                _named("inflow", f, lambda: self._set(self._pouring(f)))
        self.fluid.set_inflow(None)

    def _pouring(self, frame):
        """(shape, velocity, normal) of each tap pouring at ``frame``."""
        return tuple(p for p in (t.at(frame) for t in self.taps) if p[0] is not None)

    def _set(self, pouring):
        """The library's inflows made ``pouring`` (none: stopped)."""
        if not pouring:
            self.fluid.set_inflow(None)
            return
        (shape, v, n), rest = pouring[0], pouring[1:]
        self.fluid.set_inflow(shape, v, self.jitter, n)
        for shape, v, n in rest:
            self.fluid.add_inflow(shape, v, n)

    def apply(self, frame):
        """Sets the library's inflows as ``frame``'s step pours them, where they changed."""
        key = tuple(t.key(frame) for t in self.taps)
        if key != self._on:  # (a resumed bake: from its first frame's)
            self._set(self._pouring(frame))
            self._on = key

    def forget(self):
        """Stops the library's inflows (the forecast's are not the step's)."""
        self.fluid.set_inflow(None)
        self._on = None

    def alone(self, frame):
        """[(tap, (rate, points))] of each tap pouring at ``frame``, as it pours alone."""
        out = []
        for k, tap in enumerate(self.taps):
            shape, v, n = tap.at(frame)
            if shape is None:
                continue
            key = (k, tap.key(frame))
            if key not in self._alone:
                self.fluid.set_inflow(shape, v, normal=n)
                self._alone[key] = (self.fluid.inflow_rate, self.fluid.inflow_points)
            out.append((k, self._alone[key]))
        return out

    def scalar_inputs(self):
        """A single tap's velocity and Normal for the whole bake (as bakes before listed
        them); by frame, and for several taps, frame_inputs has them."""
        if self.many or not self.any:
            return {}
        tap = self.taps[0]
        out = {}
        if not tap.velocity.by_frame:
            out["inflow velocity"] = list(tap.velocity.values[None])
        if not tap.normal.by_frame and tap.normal.values[None]:
            out["inflow normal"] = tap.normal.values[None]
        return out

    def frame_inputs(self, frame):
        """The shapes, velocities and Normals ``frame``'s step pours with."""
        if not self.any:
            return {}
        pours = [t.at(frame) for t in self.taps]
        if not self.many:
            tap, (shape, v, n) = self.taps[0], pours[0]
            return {"inflow": shape_digest(shape),
                    **({"inflow velocity": arrays.digest(np.array(v, np.float32))}
                       if tap.velocity.by_frame else {}),
                    **({"inflow normal": arrays.digest(np.array([n], np.float32))}
                       if tap.normal.by_frame else {})}
        # (each tap's shape; the velocities and Normals of those pouring, by tap)
        on = [(k, v, n) for k, (shape, v, n) in enumerate(pours) if shape is not None]
        return {"inflow": _shapes_digest(shape for shape, _, _ in pours),
                "inflow velocity": arrays.digest(
                    np.array([(k,) + tuple(v) for k, v, _ in on], np.float32).reshape(-1, 4)),
                "inflow normal": arrays.digest(
                    np.array([(k, n) for k, _, n in on], np.float32).reshape(-1, 2))}


class Outflows:
    """The outflow input (``outflow`` one {frame: shape} or a list of them, one per drain),
    each shape checked by the library before the first frame (as the inflows')."""

    def __init__(self, inp, fluid, simulating):
        given = inp.get("outflow") or {}
        self.many = isinstance(given, list)
        names = [f"outflow[{k}]" for k in range(len(given))] if self.many else ["outflow"]
        self.drains = [schedule(sh, name)
                       for sh, name in zip(given if self.many else [given], names)]
        self.keys = [sorted(d) for d in self.drains]
        self.any = any(self.drains)
        self.fluid, self._on = fluid, None
        if self.any and not simulating:
            raise errors.InvalidArgument("outflow: only the simulation (source SIMULATE) "
                                         "drains an outflow")
        for drain, name in zip(self.drains, names):
            for f in sorted(drain):
                if drain[f] is not None:
                    _named(name, f, lambda: self.fluid.set_outflow(drain[f]))
        self.fluid.set_outflow(None)

    def _at(self, frame):
        """Each drain's shape at ``frame`` (None: closed)."""
        out = []
        for drain, keys in zip(self.drains, self.keys):
            key = key_at(keys, frame)
            out.append(None if key is None else drain[key])
        return out

    def opened(self, frame):
        """Whether a drain is open at ``frame``."""
        return any(sh is not None for sh in self._at(frame))

    def apply(self, frame):
        """Sets the library's drains as ``frame``'s step drains, where they changed."""
        key = tuple(key_at(keys, frame) for keys in self.keys)
        if key != self._on:
            shapes = [sh for sh in self._at(frame) if sh is not None]
            self.fluid.set_outflow(shapes[0] if shapes else None)
            for shape in shapes[1:]:
                self.fluid.add_outflow(shape)
            self._on = key

    def frame_inputs(self, frame):
        """The shapes ``frame``'s step drains into (a resume must match them)."""
        if not self.any:
            return {}
        shapes = self._at(frame)
        return {"outflow": _shapes_digest(shapes) if self.many else shape_digest(shapes[0])}
