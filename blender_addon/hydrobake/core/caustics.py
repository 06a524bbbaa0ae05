"""Caustic maps (hbk_caustics_*): light refracted by a height-field water surface onto the
ground, exact-area rasterised, energy conserving. Calls on numpy arrays; a Workspace keeps a
render's scratch memory from one frame to the next."""
import ctypes

import numpy as np

from . import _lib, args, arrays, errors
from ._lib import Image, Message, P, Progress, check_message, hbk_result_t
from .handle import Owner
from .params import ParamSpec


class Stats(ctypes.Structure):
    """Where the light went, per RGB channel, in W."""
    _fields_ = [(n, ctypes.c_double * 3) for n in ("entered", "absorbed", "ground", "dry")]

    def as_dict(self):
        return {n: tuple(getattr(self, n)) for n, _ in self._fields_}


_lib.check_mirror(Stats, "hbk_caustics_stats_t")
_lib.declare([
    ("hbk_caustics_render", hbk_result_t,
     [ctypes.c_void_p, P(Image), P(Image), ctypes.c_float, P(Image), P(Stats), P(Progress),
      P(Message)], check_message),
    ("hbk_caustics_render_with", hbk_result_t,
     [ctypes.c_void_p, ctypes.c_void_p, P(Image), P(Image), ctypes.c_float, P(Image), P(Stats),
      P(Progress), P(Message)], check_message),
    ("hbk_caustics_workspace_create", hbk_result_t, [P(ctypes.c_void_p), P(Message)],
     check_message),
    ("hbk_caustics_workspace_destroy", None, [ctypes.c_void_p]),
    ("hbk_caustics_workspace_bytes", ctypes.c_size_t, [ctypes.c_void_p]),
    ("hbk_caustics_view", hbk_result_t,
     [ctypes.c_void_p, P(Image), P(Image), ctypes.c_float, P(ctypes.c_float * 3), P(Image),
      P(Image), P(Message)], check_message),
    ("hbk_caustics_lit_ground", hbk_result_t,
     [P(Image), P(Image), ctypes.c_int32, P(Image), P(Message)], check_message),
])

_spec = None


def spec():
    global _spec
    if _spec is None:
        _spec = ParamSpec("caustics")
    return _spec


def _struct(params):
    return params if isinstance(params, spec().struct) else spec().to_struct(params or {})


class Workspace(Owner):
    """Scratch memory of caustic renders (hbk_caustics_workspace_t), kept between frames: a
    sequence of renders then does not pay for fresh memory each frame. Same results."""

    def __init__(self):
        h = ctypes.c_void_p()
        _lib.lib.hbk_caustics_workspace_create(ctypes.byref(h), Message())
        self._own(h.value, _lib.lib.hbk_caustics_workspace_destroy)

    @property
    def nbytes(self):
        return int(_lib.lib.hbk_caustics_workspace_bytes(self.h))


def render(water_height, ground_height, cell_size, size, params=None, progress=None,
           out=None, workspace=None):
    """The caustic map, (size[1], size[0], 4) float32 RGBA (A = 1), and the Stats.

    ``water_height``/``ground_height``: (H, W) heights in m at cell centres. ``workspace``: a
    Workspace to keep scratch memory in (for frame after frame), or None."""
    p = _struct(params)
    wh = args.float32_array(water_height, "water_height")
    gh = args.float32_array(ground_height, "ground_height")
    if workspace is not None and not isinstance(workspace, Workspace):
        raise errors.InvalidArgument(f"workspace: must be a caustics.Workspace or None, got "
                                     f"{type(workspace).__name__}")
    if out is None:
        # The library's limit on an image's side, checked before numpy allocates the map
        # (size = (2**31, 1) asked numpy for 32 GiB).
        w, h = (args.integer(v, f"size[{k}]", 1, arrays.MAX_IMAGE_SIDE)
                for k, v in enumerate(args.sequence(size, "size", 2, "integers")))
        out = np.zeros((h, w, 4), np.float32)
    stats = Stats()
    call = (ctypes.byref(p), arrays.as_image(wh, "water_height", 1),
            arrays.as_image(gh, "ground_height", 1), args.number(cell_size, "cell_size"),
            arrays.as_image(out, "out", (3, 4), writable=True), stats, args.progress(progress),
            Message())
    if workspace is None:
        _lib.lib.hbk_caustics_render(*call)
    else:
        _lib.lib.hbk_caustics_render_with(workspace.h, *call)
    return out, stats


def view(water_height, ground_height, cell_size, camera, params=None, channels=4):
    """View refraction: per surface sample (u, v[, path length, reflectance]) of the ground
    hit, and the reflected view direction (H, W, 3)."""
    p = _struct(params)
    wh = args.float32_array(water_height, "water_height")
    gh = args.float32_array(ground_height, "ground_height")
    wh_img = arrays.as_image(wh, "water_height", 1)  # before the outputs are shaped from it
    # out_uv's channels (hbk_caustics_view), checked before numpy allocates from them.
    channels = args.integer(channels, "channels", 2, 4)
    uv = np.zeros(wh.shape + (channels,), np.float32)
    refl = np.zeros(wh.shape + (3,), np.float32)
    cam = args.numbers(camera, "camera", 3)
    _lib.lib.hbk_caustics_view(ctypes.byref(p), wh_img,
                               arrays.as_image(gh, "ground_height", 1),
                               args.number(cell_size, "cell_size"),
                               cam, arrays.as_image(uv, "out_uv", (2, 3, 4), writable=True),
                               arrays.as_image(refl, "out_reflect", 3, writable=True),
                               Message())
    return uv, refl


def lit_ground(texture, caustic_map, edge="WRAP"):
    """texture x caustic map, per channel (the paper's lit ground)."""
    from .image import EDGES
    edge = EDGES[args.choice(edge, "edge", EDGES)]
    tex = args.float32_array(texture, "texture")
    cm = args.float32_array(caustic_map, "caustic_map")
    out = np.empty_like(tex)
    _lib.lib.hbk_caustics_lit_ground(arrays.as_image(tex, "texture", (3, 4)),
                                     arrays.as_image(cm, "caustic_map", (3, 4)), edge,
                                     arrays.as_image(out, "out", (3, 4), writable=True),
                                     Message())
    return out


def _bilinear(img, x, y):
    """img (h, w, c) sampled at pixel coordinates (x, y) (centres at integers), clamped."""
    h, w = img.shape[:2]
    x = np.clip(x, 0, w - 1)
    y = np.clip(y, 0, h - 1)
    x0, y0 = np.floor(x).astype(int), np.floor(y).astype(int)
    x1, y1 = np.minimum(x0 + 1, w - 1), np.minimum(y0 + 1, h - 1)
    tx, ty = (x - x0)[..., None], (y - y0)[..., None]
    top = img[y0, x0] * (1 - tx) + img[y0, x1] * tx
    bot = img[y1, x0] * (1 - tx) + img[y1, x1] * tx
    return top * (1 - ty) + bot * ty


def _environment(environment):
    """view_image's environment as (h, w, c) float32, c 1 (grey, as a 2-D image is), 3 or 4.
    An empty one has nothing to sample (numpy failed on it with an IndexError)."""
    env = args.float32_array(environment, "environment")
    if env.ndim == 2:
        env = env[..., None]  # as (h, w) it would broadcast against the view's rows
    if env.ndim != 3 or env.shape[2] not in (1, 3, 4) or min(env.shape[:2]) < 1:
        raise errors.InvalidArgument(f"environment: must have shape (height, width[, 1|3|4]), "
                                     f"at least 1 x 1, got {env.shape}")
    bad = ~(np.abs(env) <= 1e6)  # a NaN or infinite texel would come out in the reflection
    if bad.any():
        y, x, c = np.argwhere(bad)[0]
        raise errors.InvalidArgument(f"environment at pixel ({x}, {y}) = {env[y, x, c]:g}: must "
                                     "be a finite number in [-1e+06, 1e+06]")
    return env


def view_image(water_height, ground_height, cell_size, camera, ground_texture, caustic_map,
               environment=None, params=None, heading=0.0):
    """The paper's rendering of the water seen from ``camera`` (§3.2), one pixel per surface
    sample: the lit ground (texture x caustic map) looked up where the refracted view ray hits
    it, attenuated by absorption along the path in water, plus the Fresnel reflection of the
    ``environment`` (a latitude-longitude image, +z up; None = black). ``heading``: the grid's
    x axis from the environment's, in radians about z (a grid turned with its pool sees the
    sky turned back). (H, W, 3) float32."""
    p = _struct(params)
    heading = args.number(heading, "heading")
    tex = args.float32_array(ground_texture, "ground_texture")
    if not (tex.ndim == 2 or tex.ndim == 3 and tex.shape[2] in (3, 4)):
        raise errors.InvalidArgument(f"ground_texture: must have shape (height, width[, 3|4]), "
                                     f"got {tex.shape}")
    env = None if environment is None else _environment(environment)
    uv, refl = view(water_height, ground_height, cell_size, camera, p, channels=4)
    if tex.ndim == 2:
        tex = np.repeat(tex[..., None], 3, axis=2)
    cm = args.float32_array(caustic_map, "caustic_map")
    if tex.shape[2] == 4:
        tex = np.ascontiguousarray(tex[..., :3])
    lit = lit_ground(tex, cm, edge="CLAMP")
    th, tw = lit.shape[:2]
    ground = _bilinear(lit, uv[..., 0] * tw - 0.5, uv[..., 1] * th - 0.5)[..., :3]
    absorb = np.exp(-np.asarray(p.absorption[:3], np.float64)[None, None, :] * uv[..., 2:3])
    R = uv[..., 3:4]
    color = (1.0 - R) * ground * absorb
    if env is not None:
        eh, ew = env.shape[:2]
        lon = np.arctan2(refl[..., 1], refl[..., 0]) + heading
        lon = np.mod(lon + np.pi, 2 * np.pi) - np.pi
        lat = np.arcsin(np.clip(refl[..., 2], -1.0, 1.0))
        sky = _bilinear(env, (0.5 + lon / (2 * np.pi)) * ew - 0.5,
                        (0.5 + lat / np.pi) * eh - 0.5)[..., :3]
        color = color + R * sky
    return color.astype(np.float32)
