"""Snow attachment on one mesh: flakes fall through the snow volume for ``substeps`` steps per
frame and stick by temperature, water content and material.

Inputs:
    positions      (V, 3) float32 world-space vertices (the mesh at rest)
    triangles      (T, 3) int32
    uvs            (T, 3, 2) float32 UV per triangle corner (TRIANGLES mode)
    material_index (T,) int32 material slot per triangle
    materials      [(catch_chance, melts, sheds)] per slot
    transforms     {frame: (4, 4) matrix} rigid motion applied to positions (optional), from
                   that frame until the next one given; with part_vertices,
                   {frame: (P, 4, 4)}: one matrix per part
    part_vertices  (P,) int vertex counts of consecutive parts of positions (objects that
                   move each their own way: a person and the roof over them); optional
    frame_positions {frame: (V, 3) float32} world-space vertices of a mesh that deforms (a
                   walking person), from that frame until the next one given; instead of
                   transforms (optional)
    substeps       solver steps per frame (default 1)
    flakes         True to also write the falling flakes as points per frame

Streams per frame:
    coverage_####.exr  RGBA: white snow (RGB 1) over transparent, A = coverage. Half.
    depth_####.exr     Y = snow depth in m (for displacement; Blender reads it as grey). Float.
    flakes_####.npz    "positions": (N, 3) flake positions (only with flakes=True)
"""
import bisect

import numpy as np

from .. import errors
from ..arrays import digest
from ..snow import Snow
from . import register
from .base import Effect, plain


@register
class SnowEffect(Effect):
    name = "snow"
    streams = ("coverage", "depth", "flakes")

    @classmethod
    def groups(cls):
        return {"snow": Snow.spec()}

    def __init__(self, params=None, inputs=None):
        super().__init__(params, inputs)
        inp = self.inputs
        for key in ("positions", "triangles"):
            if inp.get(key) is None:
                raise errors.InvalidArgument(f"{key}: the snow effect needs a mesh")
        self.snow = Snow(self.params_dict()["snow"])
        try:
            self.positions = np.ascontiguousarray(inp["positions"], np.float32).reshape(-1, 3)
            self.triangles = np.ascontiguousarray(inp["triangles"], np.int32).reshape(-1, 3)
            self.substeps = int(inp.get("substeps", 1))
            if not 1 <= self.substeps <= 100000:
                raise errors.InvalidArgument(f"substeps = {self.substeps}: must be in "
                                             "[1, 100000]")
            self.snow.set_materials(inp.get("materials") or [(0.0, False, False)])
            self.transforms = inp.get("transforms") or {}
            self.parts = self._parts(inp.get("part_vertices"))
            self.shapes = self._shapes(inp.get("frame_positions") or {})
            self._keys = sorted(self.shapes or self.transforms)
            self._placed = {}  # transform's frame -> digest of the vertices it places
            self._set_mesh(None)
        except BaseException:
            self.snow.close()
            raise
        self.with_flakes = bool(inp.get("flakes", False))
        if not self.with_flakes:
            self.streams = ("coverage", "depth")

    def scalar_inputs(self):
        """Substeps per frame, the material slots' sticking and whether flakes are written."""
        materials = self.inputs.get("materials") or [(0.0, False, False)]
        return plain({"substeps": self.substeps, "flakes": self.with_flakes,
                      "materials": [[float(c), bool(m), bool(s)] for c, m, s in materials]})

    def scene_inputs(self):
        """The mesh's triangles and UVs, and each triangle's material slot."""
        inp = self.inputs
        return {"mesh": digest(self.triangles, inp.get("uvs")),
                "faces' material slots": digest(inp.get("material_index"))}

    def frame_inputs(self, frame):
        """Where the mesh's vertices are at ``frame`` (the latest shape or transform given up
        to it, as step sets them): the same for a mesh given in the world as for one given
        at rest with transforms that put it there (Blender gives those once it moves)."""
        i = bisect.bisect_right(self._keys, frame)
        key = self._keys[i - 1] if i else None
        if key not in self._placed:
            self._placed[key] = digest(self._positions(key))
        return {"mesh position": self._placed[key]}

    def _parts(self, counts):
        """Vertex ranges [(start, end)] the per-part transforms move; None: one for all."""
        if counts is None:
            for f, m in self.transforms.items():
                if np.shape(m) != (4, 4):
                    raise errors.InvalidArgument(f"transforms[{f}]: shape {np.shape(m)}, need "
                                                 "(4, 4) (or part_vertices)")
            return None
        counts = [int(c) for c in counts]
        if any(c < 0 for c in counts) or sum(counts) != len(self.positions):
            raise errors.InvalidArgument(f"part_vertices: {counts} must be counts adding up to "
                                         f"the {len(self.positions)} positions")
        for f, m in self.transforms.items():
            if np.shape(m) != (len(counts), 4, 4):
                raise errors.InvalidArgument(f"transforms[{f}]: shape {np.shape(m)}, need "
                                             f"({len(counts)}, 4, 4), one per part")
        ends = np.cumsum(counts)
        return list(zip((ends - counts).tolist(), ends.tolist()))

    def _shapes(self, given):
        """The deformed meshes by frame, each checked to be the mesh's vertices."""
        if given and self.transforms:
            raise errors.InvalidArgument("frame_positions: give them or transforms, not both "
                                         "(frame_positions are in world space)")
        out = {}
        for f, p in given.items():
            p = np.ascontiguousarray(p, np.float32)
            if p.shape != self.positions.shape:
                raise errors.InvalidArgument(f"frame_positions[{f}]: shape {p.shape}, need "
                                             f"{self.positions.shape} (the mesh's vertices)")
            out[f] = p
        return out

    def _positions(self, frame):
        """The vertices at the shape or moved by the transform given at ``frame`` (None: at
        rest)."""
        if frame in self.shapes:
            return self.shapes[frame]
        pos = self.positions
        m = self.transforms.get(frame)
        if m is not None:
            m = np.asarray(m, np.float64)
            if self.parts is None:
                pos = (pos.astype(np.float64) @ m[:3, :3].T + m[:3, 3]).astype(np.float32)
            else:
                pos = np.concatenate([
                    (pos[a:b].astype(np.float64) @ mk[:3, :3].T + mk[:3, 3]).astype(np.float32)
                    for (a, b), mk in zip(self.parts, m)])
        return pos

    def _set_mesh(self, frame):
        self._mesh_frame = frame  # whose transform the mesh has (None: at rest)
        self.snow.set_mesh(self._positions(frame), self.triangles, self.inputs.get("uvs"),
                           self.inputs.get("material_index"))

    def step(self, frame, progress):
        # The shape or transform of the latest frame given up to this one: what a bake that
        # never stopped has set by now. A checkpoint holds no mesh, so a bake resumed between
        # two given frames sets it here too (it stepped the mesh at rest).
        i = bisect.bisect_right(self._keys, frame)
        key = self._keys[i - 1] if i else None
        if key != self._mesh_frame:
            self._set_mesh(key)
        self.snow.step(self.substeps, progress)

    def outputs(self, frame):
        cov = self.snow.coverage()
        depth = self.snow.depth()
        out = {
            "coverage": ("exr", {c: cov[..., i] for i, c in enumerate("RGBA")}, {"half": True}),
            "depth": ("exr", {"Y": depth}, {}),
        }
        if self.with_flakes:
            out["flakes"] = ("npz", {"positions": self.snow.flakes()}, {})
        return out

    def save_state(self):
        return self.snow.save_state()

    def load_state(self, data):
        self.snow.load_state(data)

    def close(self):
        self.snow.close()
