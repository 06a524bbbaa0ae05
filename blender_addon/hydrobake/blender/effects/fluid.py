"""Fluid texturing in Blender: the domain object's bounding box is the simulation box; the
fluid is the built-in SPH (filling a Fill object's shape), a particle system's particles, or a
baked Mantaflow liquid (its velocity cache, and its liquid mesh for the surface). The bake
becomes a Volume object reading the VDB sequence and a surface mesh that follows the frame,
with a material that blends the sample textures at the advected uvw, cross-fading fields A
and B."""
import hashlib
import os
import warnings

import bpy
import mathutils
import numpy as np

from ...core import mantaflow, solid_textures
from .. import paths
from ..bridge import (animation, frame_meshes, helper_objects, mesh_fields, meshes, tileable,
                      volumes)
from ..bridge.depsgraph import enabled as depsgraph_enabled
from ..bridge.depsgraph import evaluated as evaluated_depsgraph, evaluated_object
from . import fluid_paint, register_effect
from .base import BakeWarning, BlenderEffect, offers
from .fluid_paint import FEATURES


OPEN = 3.0e38  # a feature bound that does not matter
SHOWN = "shown_as"  # in the settings: the domain's (display_type, hide_render) before its bake
MAX_OBSTACLES = 64  # HBK_FLUID_MAX_OBSTACLES
DEFORMING_SIDE = 40  # a deforming mesh's field points along its longest side, every frame


def _round(obj, depsgraph):
    """(centre, radius) in the world of a mesh whose evaluated vertices all lie within 2% of
    one distance from the centre of their box and whose faces' centres lie near it too (a UV
    or ico sphere, however turned or uniformly scaled), else None: such an obstacle is a
    sphere, not its bounding box (a ball would push the water as a cube does). (A cylinder's
    vertices lie on a sphere as well, but its caps' centres are deep inside it.)"""
    if obj.type != "MESH":
        return None
    ev = obj.evaluated_get(depsgraph)
    mesh = ev.to_mesh()
    try:
        pos = np.empty(len(mesh.vertices) * 3, np.float64)
        mesh.vertices.foreach_get("co", pos)
        mid = np.empty(len(mesh.polygons) * 3, np.float64)
        mesh.polygons.foreach_get("center", mid)
    finally:
        ev.to_mesh_clear()
    if len(pos) < 3 * 12:  # a box has 8: no sphere
        return None
    m = np.array(ev.matrix_world, np.float64)
    world = pos.reshape(-1, 3) @ m[:3, :3].T + m[:3, 3]
    centre = (world.min(axis=0) + world.max(axis=0)) / 2
    d = np.linalg.norm(world - centre, axis=1)
    if d.max() <= 0.0 or d.max() - d.min() > 0.02 * d.max():
        return None
    # a face's centre lies within its sag of the sphere: at 0.95 r on an ico sphere of 42
    # vertices, at 0.86 r at least on a UV sphere of 8 segments and 4 rings
    faces = mid.reshape(-1, 3) @ m[:3, :3].T + m[:3, 3]
    if len(faces) and np.linalg.norm(faces - centre, axis=1).min() < 0.8 * d.max():
        return None
    return tuple(map(float, centre)), float(d.max())


def _fill_shape(context, obj, spacing, role="Fill", made=None):
    """The shape the Fill (or Inflow, or Outflow) object's water takes, as the core's
    fill_shape takes it: a ball as a sphere; a mesh, curve, text or metaball family as its
    signed distance field (made as an obstacle's is); an Inflow's or Outflow's open mesh (a
    plane) as the sheet around its faces (mesh_fields.sheet_shape: ``made["shape"]`` holds
    it, with its thickness and a flat one's normal); else None, its box (a box-shaped mesh,
    an object without faces, or a Fill's open one, which is warned of). With ``made`` (a
    dict kept between the frames of one object) an object that does not deform has its
    field made once and placed where it is, and each warning is given once."""
    if obj.type not in animation.SHAPED_TYPES:
        return None
    made = {} if made is None else made
    boxed, use = (("the water drains from its bounding box", "drain into") if role == "Outflow"
                  else ("the water fills its bounding box", "fill"))

    def warn(text):
        if text not in made.setdefault("warned", set()):
            made["warned"].add(text)
            warnings.warn(text, BakeWarning)
    dg = evaluated_depsgraph(context)
    if not depsgraph_enabled(dg.view_layer, obj):
        # not evaluated (an object appended beside the domain, not in the scene): its box,
        # as before shapes were read; said where the box is not its shape
        boxy = obj.type == "MESH" and len(obj.data.vertices) > 0
        if boxy:
            co = np.empty(3 * len(obj.data.vertices), np.float64)
            obj.data.vertices.foreach_get("co", co)
            co = co.reshape(-1, 3)
            boxy = mesh_fields.is_box(co, co.min(axis=0), co.max(axis=0))
        if not boxy:
            warn(f"{role}: {obj.name!r} is not evaluated in view layer "
                 f"{dg.view_layer.name!r} (Show in Viewports is off, or none of its "
                 "collections is in the scene, included and enabled in viewports), so "
                 f"its shape cannot be read: {boxed}; turn on Show In > Viewports and "
                 f"include one of its collections to {use} its shape")
        return None
    ball = _round(obj, dg)
    if ball is not None:
        return ("sphere",) + ball
    ev = evaluated_object(obj, dg, role)
    if "shape" not in made or animation.may_deform(obj):
        made["shape"] = mesh_fields.mesh_shape(ev, spacing)
        if role != "Fill" and (made["shape"] is None or not made["shape"].signed):
            # an open mesh (a plane): the sheet it pours from or drains into
            made["shape"] = mesh_fields.sheet_shape(ev, spacing) or made["shape"]
    shape = made["shape"]
    if shape is None:
        return None
    if not shape.signed:
        warn(f"{role}: {obj.name}'s faces do not all face out (a hole, or normals "
             f"inside), so it has no inside to {use}: {boxed}")
        return None
    return shape.placed(ev.matrix_world, True)


def _same_shape(a, b):
    """Whether two shapes as _fill_shape gives them (or None) are the same (fields compared
    whole)."""
    if a is None or b is None:
        return a is b
    return len(a) == len(b) and all(np.array_equal(x, y) for x, y in zip(a, b))


def _warn_unsigned(obj):
    """The BakeWarning for an obstacle taken as a thin shell (its field unsigned)."""
    fix = "recalculate its normals (Mesh > Normals) and close it" if obj.type == "MESH" else \
        "close its shape (a cyclic spline, Fill Mode Full; Extrude for a text) or convert it " \
        "to a mesh"
    warnings.warn(f"Obstacles: {obj.name}'s faces do not all face out (a hole, or normals "
                  "inside): it is taken as a thin shell the water stays off on both sides; "
                  f"{fix} for a solid", BakeWarning)


def _sprays(normal):
    """Whether a Normal (one, or {frame: one}) is above 0 at some frame."""
    return any(v > 0.0 for v in (normal.values() if isinstance(normal, dict) else [normal]))


def _flow_objects(settings, key):
    """The objects that pour (``key`` "inflow") or drain ("outflow"): the Inflow (Outflow),
    then those of the Inflows (Outflows) collection, each shape once (a metaball family's
    members are one surface: the first of them)."""
    one, many = getattr(settings, f"{key}_object"), getattr(settings, f"{key}_collection")
    found = [one] if one is not None else []
    if many is not None:
        found += list(many.all_objects)
    first = {}
    for o in found:
        first.setdefault(meshes.shape_holder(o), o)
    return list(first.values())


class HYDROBAKE_PG_fluid_rule(bpy.types.PropertyGroup):
    """Feature paint (paper §3.1): where a feature lies in [low, high], use the texture."""
    texture: bpy.props.IntProperty(name="Texture", default=1, min=0, max=7,
                                   description="Sample texture given by the rule")
    feature: bpy.props.EnumProperty(
        name="Feature", default="DENSITY_RATE",
        items=[(f, f.replace("_", " ").title(), "") for f in FEATURES],
        description="The local feature the rule reads")
    low: bpy.props.FloatProperty(name="Low", default=0.0, description="Lower bound")
    high: bpy.props.FloatProperty(name="High", default=1.0, description="Upper bound")


@offers("an object with a particle system")
def _has_particles(_self, obj):
    """Offer only objects that emit particles (PARTICLES reads the first system)."""
    return len(obj.particle_systems) > 0


@offers("a Mantaflow liquid domain")
def _is_liquid_domain(_self, obj):
    """Offer only Mantaflow liquid domains."""
    return any(m.type == "FLUID" and m.fluid_type == "DOMAIN" and
               m.domain_settings.domain_type == "LIQUID" for m in obj.modifiers)


def _is_sample_group(_self, tree):
    """A shader node group usable as a sample texture: a vector in, a colour out."""
    return (tree.bl_idname == "ShaderNodeTree" and _group_socket(tree, "INPUT") is not None
            and _group_socket(tree, "OUTPUT") is not None)


def _group_socket(tree, side):
    """Name of a node group's first vector input (side INPUT) or colour output (OUTPUT)."""
    socks = tree.inputs if side == "INPUT" else tree.outputs
    want = ("NodeSocketVector",) if side == "INPUT" else ("NodeSocketColor",)
    return next((sk.name for sk in socks if sk.bl_socket_idname in want), None)


class HYDROBAKE_PG_fluid_sample(bpy.types.PropertyGroup):
    """One sample texture: a shader node group evaluated at the advected uvw, or a voxel
    solid texture (a VDB tile) sampled at the surface's vertices."""
    group: bpy.props.PointerProperty(
        name="Node Group", type=bpy.types.NodeTree, poll=_is_sample_group,
        description="A shader node group with a Vector input and a Color output, evaluated "
                    "at the advected uvw (times the texture's scale). Empty: a built-in sample")
    voxel_file: bpy.props.StringProperty(
        name="Voxel Texture", subtype="FILE_PATH",
        description="A voxel solid texture: an OpenVDB file whose first grid (colour or grey) "
                    "is one tile over uvw [0, 1). Sampled at every surface vertex; wins over "
                    "the node group")


class HYDROBAKE_OT_fluid_sample(bpy.types.Operator):
    """Add a sample texture slot (pick its node group), or remove the last one"""
    bl_idname = "hydrobake.fluid_sample"
    bl_label = "Sample Texture"
    bl_options = {"REGISTER", "UNDO"}

    action: bpy.props.EnumProperty(items=[("ADD", "Add", ""), ("REMOVE", "Remove", "")])

    def execute(self, context):
        obj = context.object
        s = getattr(obj, "hydrobake_fluid", None) if obj else None
        if s is None:
            return {"CANCELLED"}
        if self.action == "ADD":
            if len(s.samples) >= s.fluid.textures:
                self.report({"ERROR"}, f"textures = {s.fluid.textures}: raise it to add a "
                                       "sample")
                return {"CANCELLED"}
            s.samples.add()
        elif len(s.samples):
            s.samples.remove(len(s.samples) - 1)
        return {"FINISHED"}


class HYDROBAKE_OT_fluid_noise_texture(bpy.types.Operator):
    """Make a tileable 3D noise voxel texture with the core (a VDB next to the .blend) and use
    it for this sample"""
    bl_idname = "hydrobake.fluid_noise_texture"
    bl_label = "Make Noise Voxel Texture"
    bl_options = {"REGISTER", "UNDO"}

    index: bpy.props.IntProperty(min=0, max=7)
    size: bpy.props.IntProperty(name="Size", default=64, min=8, max=256)
    period: bpy.props.IntProperty(name="Period", default=4, min=1, max=64)
    seed: bpy.props.IntProperty(name="Seed", default=0, min=0)

    def execute(self, context):
        obj = context.object
        s = getattr(obj, "hydrobake_fluid", None) if obj else None
        if s is None or self.index >= len(s.samples):
            self.report({"ERROR"}, "No such sample texture slot")
            return {"CANCELLED"}
        if not bpy.data.filepath:
            self.report({"ERROR"}, "Save the .blend first: the texture is written next to it")
            return {"CANCELLED"}
        rel = f"//hydrobake_textures/noise_{self.size}_{self.period}_{self.seed}.vdb"
        path = bpy.path.abspath(rel)
        os.makedirs(os.path.dirname(path), exist_ok=True)
        solid_textures.write_noise_vdb(path, self.size, self.period, seed=self.seed)
        s.samples[self.index].voxel_file = rel
        return {"FINISHED"}


@register_effect
class FluidBlender(BlenderEffect):
    name = "fluid"
    label = "Fluid Texturing"
    icon = "MOD_FLUID"
    presets = {
        "Preview (32³)": {"fluid": {"resolution": (32, 32, 32), "substeps": 10}},
        "Final (64³)": {"fluid": {"resolution": (64, 64, 64), "substeps": 20}},
    }

    @classmethod
    def extra_properties(cls):
        return dict(
            fill_object=bpy.props.PointerProperty(
                name="Fill", type=bpy.types.Object,
                description="SIMULATE: particles fill this object's shape at frame one (a "
                            "ball, a closed mesh, curve, text or metaball; a box-shaped one or "
                            "an object without faces: its bounding box). Empty with an Inflow: "
                            "the domain starts dry"),
            fill_velocity=bpy.props.FloatVectorProperty(
                name="Initial Velocity", size=3, default=(0.0, 0.0, 0.0), min=-100.0,
                max=100.0, subtype="VELOCITY", unit="VELOCITY",
                description="SIMULATE: the velocity the Fill's water starts with (world axes; "
                            "a ball of water thrown at a wall)"),
            fill_source=bpy.props.FloatProperty(
                name="Source", default=1.0, min=0.0, max=10.0, soft_max=2.0,
                description="SIMULATE: how much of the Fill object's own motion over the first "
                            "frame its water starts with, added to the Initial Velocity (as "
                            "Mantaflow's Source: 1, a keyed ball of water flies on as keyed; 0, "
                            "the Initial Velocity alone)"),
            inflow_object=bpy.props.PointerProperty(
                name="Inflow", type=bpy.types.Object,
                description="SIMULATE: water pours in from this object's shape (a tap, a "
                            "hose; an open mesh such as a Plane: the sheet around its faces), "
                            "as fast as the water before leaves it, from Inflow Start to "
                            "Inflow End; followed when it moves. Stops at Max Particles"),
            inflow_collection=bpy.props.PointerProperty(
                name="Inflows", type=bpy.types.Collection,
                description="SIMULATE: more taps: every object in this collection pours as "
                            "the Inflow does, from its own shape, with the settings below "
                            "(Local Velocity turns each with its own axes; Source adds each "
                            "one's own motion)"),
            inflow_velocity=bpy.props.FloatVectorProperty(
                name="Inflow Velocity", size=3, default=(0.0, 0.0, -1.0), min=-100.0,
                max=100.0, subtype="VELOCITY", unit="VELOCITY",
                description="SIMULATE: the velocity the Inflow's water leaves at (world "
                            "axes); the faster, the more water a second"),
            inflow_normal=bpy.props.FloatProperty(
                name="Normal", default=0.0, min=0.0, max=100.0, soft_max=10.0,
                unit="VELOCITY",
                description="SIMULATE: speed along the Inflow's surface normal, added to the "
                            "Inflow Velocity (as Mantaflow's Normal initial velocity); above 0 "
                            "the water leaves from the object's surface wherever that velocity "
                            "points out of it: a sprinkler, a fountain head"),
            inflow_local=bpy.props.BoolProperty(
                name="Local Velocity", default=False,
                description="SIMULATE: the Inflow Velocity is in the Inflow's own axes and "
                            "turns with it (a hose that sweeps, a nozzle that rotates); off: "
                            "world axes"),
            inflow_source=bpy.props.FloatProperty(
                name="Source", default=1.0, min=0.0, max=10.0, soft_max=2.0,
                description="SIMULATE: how much of the Inflow object's own motion its water "
                            "takes on, added to the Inflow Velocity (as Mantaflow's Source: 1, "
                            "a hose swung sideways throws its water sideways; 0, the Inflow "
                            "Velocity alone)"),
            inflow_start=bpy.props.IntProperty(
                name="Inflow Start", default=1, min=-1048574, max=1048574,
                description="SIMULATE: the first frame the Inflow pours"),
            inflow_end=bpy.props.IntProperty(
                name="Inflow End", default=250, min=-1048574, max=1048574,
                description="SIMULATE: the last frame the Inflow pours"),
            outflow_object=bpy.props.PointerProperty(
                name="Outflow", type=bpy.types.Object,
                description="SIMULATE: a drain: the water entering this object's shape (an "
                            "open mesh's: the sheet around its faces) goes (so an Inflow can "
                            "pour for good), from Outflow Start to Outflow "
                            "End; followed when it moves, and drains nothing at frames it is "
                            "outside the domain"),
            outflow_collection=bpy.props.PointerProperty(
                name="Outflows", type=bpy.types.Collection,
                description="SIMULATE: more drains: every object in this collection drains "
                            "as the Outflow does, its own shape, from Outflow Start to Outflow "
                            "End"),
            outflow_start=bpy.props.IntProperty(
                name="Outflow Start", default=1, min=-1048574, max=1048574,
                description="SIMULATE: the first frame the Outflow drains (a plug pulled)"),
            outflow_end=bpy.props.IntProperty(
                name="Outflow End", default=250, min=-1048574, max=1048574,
                description="SIMULATE: the last frame the Outflow drains (a plug put back)"),
            particle_object=bpy.props.PointerProperty(
                name="Particles", type=bpy.types.Object, poll=_has_particles,
                description="PARTICLES: the object whose first particle system is the fluid "
                            "(positions and velocities read every frame)"),
            liquid_domain=bpy.props.PointerProperty(
                name="Liquid Domain", type=bpy.types.Object, poll=_is_liquid_domain,
                description="VELOCITY_GRID: a Mantaflow liquid domain with a baked OpenVDB "
                            "cache; its velocity moves the textures, its liquid mesh (Mesh "
                            "baked) is the surface. Empty: this object, if it is one"),
            obstacles=bpy.props.PointerProperty(
                name="Obstacles", type=bpy.types.Collection,
                description="SIMULATE: objects the fluid flows around (a ball as a sphere, a "
                            "mesh, curve or text by its shape, metaballs named alike by the one "
                            "surface they melt into, a box-shaped one or an object without "
                            "faces as its own box turned with it), followed "
                            "frame by frame when animated or deformed"),
            paint_collection=bpy.props.PointerProperty(
                name="Paint", type=bpy.types.Collection,
                description="Empties with Paint Fluid on: local paint strokes (Object tab)"),
            samples=bpy.props.CollectionProperty(
                type=HYDROBAKE_PG_fluid_sample, name="Sample Textures",
                description="Sample texture k is the k-th entry's node group or voxel "
                            "texture; textures without an entry use the built-in noise, waves "
                            "and cells"),
            rules=bpy.props.CollectionProperty(
                type=HYDROBAKE_PG_fluid_rule, name="Feature Rules",
                description="Feature paint: a texture wherever a feature lies in a range"),
        )

    @classmethod
    def wired_objects(cls, obj, settings):
        return []  # the surface and Volume it makes are its own

    @classmethod
    def evaluated_inputs(cls, obj, settings):
        source = settings.fluid.source
        if source == "PARTICLES" and settings.particle_object is not None:
            return [("Particles", settings.particle_object)]
        if source == "VELOCITY_GRID":  # its liquid mesh, when it has one
            dom = settings.liquid_domain or obj
            mod = next((m for m in dom.modifiers
                        if m.type == "FLUID" and m.fluid_type == "DOMAIN"), None)
            if mod is not None and mod.domain_settings.use_mesh:
                return [("Liquid Domain", dom)]
        return []

    @classmethod
    def prepare(cls, context, obj, settings, params, frames):
        # The object's own box (a liquid domain's bounds would be its liquid's).
        lo, hi = meshes.data_world_bounds(obj) if obj.type == "MESH" else meshes.world_bounds(obj)
        fp = params["fluid"]
        fp["box_min"], fp["box_max"] = tuple(map(float, lo)), tuple(map(float, hi))
        fps = context.scene.render.fps / context.scene.render.fps_base
        fp["dt"] = 1.0 / fps
        cell = float(np.max((np.asarray(hi) - np.asarray(lo)) / np.asarray(fp["resolution"])))
        if fp["uvw_tile"] <= 2.0 * cell:
            # Neighbouring vertices' uvw then differ by half a tile or more, and the wrap flags
            # (paper Fig. 4) cannot tell the short way: the texture shows seams.
            warnings.warn(f"UVW Tile = {fp['uvw_tile']:g} m spans 2 grid cells or fewer (a cell "
                          f"is up to {cell:.3g} m): the texture will show seams; use more than "
                          f"{2.0 * cell:.3g} m, or a finer resolution", BakeWarning)
        inputs = {}
        if fp["source"] == 0:
            if settings.fill_object is None and not _flow_objects(settings, "inflow"):
                raise ValueError("Fill: SIMULATE needs an object whose shape the fluid fills "
                                 "(or an Inflow to pour it from)")
            if settings.fill_object is not None:
                fill = meshes.shape_holder(settings.fill_object)
                flo, fhi = meshes.world_bounds(fill)
                flo, fhi = np.maximum(flo, lo), np.minimum(fhi, hi)
                if np.any(fhi - flo < fp["particle_spacing"]):
                    # The core would fill it with no particle at all: a bake of nothing.
                    raise ValueError(f"Fill: {settings.fill_object.name!r} must overlap the "
                                     "domain's box by at least particle_spacing = "
                                     f"{fp['particle_spacing']:g} m on every axis")
                inputs["fill"] = (tuple(map(float, flo)), tuple(map(float, fhi)))
                velocity = yield from cls._fill_velocity(context, settings, fill, frames,
                                                         fp["dt"])
                if any(velocity):
                    inputs["fill_velocity"] = velocity
                shape = _fill_shape(context, fill, fp["particle_spacing"])
                if shape is not None:
                    inputs["fill_shape"] = shape
            taps = _flow_objects(settings, "inflow")
            if taps:
                inputs.update((yield from cls._inflows(context, settings, taps, fp, frames,
                                                       lo, hi)))
            drains = _flow_objects(settings, "outflow")
            if drains:
                got = []
                for obj in drains:
                    got.append((yield from cls._flow(context, settings, "Outflow", obj, fp,
                                                     frames, lo, hi)))
                inputs["outflow"] = got[0] if len(got) == 1 else got
            if settings.obstacles:
                # (a metaball family's members are one surface, held by its basis)
                found = list(dict.fromkeys(map(meshes.shape_holder,
                                               settings.obstacles.all_objects)))
                if len(found) > MAX_OBSTACLES:
                    # The core takes 64: the others would be left out, the fluid flowing
                    # through them.
                    raise ValueError(f"Obstacles: {settings.obstacles.name!r} holds "
                                     f"{len(found)} objects: must hold at most "
                                     f"{MAX_OBSTACLES} (each is a box the fluid flows around)")
                inputs["obstacles"], inputs["obstacle_path"] = yield from cls._obstacles(
                    context, found, frames, fp["particle_spacing"])
        elif fp["source"] == 1:
            if settings.particle_object is None:
                raise ValueError("Particles: PARTICLES needs an object with a particle system")
            inputs["particles"] = yield from cls._particles(
                context, settings.particle_object, frames, lo, hi)
        else:
            inputs["velocity"] = yield from cls._mantaflow(context, obj, settings, fp, frames)
        ntex = fp["textures"]
        if len(settings.samples) > ntex:
            raise ValueError(f"Sample Textures: {len(settings.samples)} entries for textures "
                             f"= {ntex}: remove some or raise textures")
        voxel = {}
        for k, sm in enumerate(settings.samples):
            if sm.voxel_file:
                path = paths.resolve(sm.voxel_file, sm.get("voxel_file_base"),
                                     sm.id_data.library)
                try:
                    voxel[k] = solid_textures.read_vdb(path)
                except Exception as exc:
                    raise ValueError(f"Sample Textures: texture {k}: {exc}") from exc
            elif sm.group is not None and not _is_sample_group(None, sm.group):
                raise ValueError(f"Sample Textures: texture {k}: node group {sm.group.name!r} "
                                 "needs a Vector input and a Color output")
        inputs["voxel_textures"] = voxel
        if settings.paint_collection:
            life = (fp["paint_duration"] + fp["paint_fade"]) / fp["dt"]  # frames
            inputs["paint"], inputs["paint_points"] = fluid_paint.strokes(
                settings.paint_collection, ntex, fluid_paint.smallest_cell(obj),
                scene=context.scene, frames=frames, life=life)
        rules = []
        for i, rule in enumerate(settings.rules):
            if rule.texture >= ntex:
                raise ValueError(f"Feature rule {i + 1}: texture = {rule.texture}: must be < "
                                 f"textures = {ntex}")
            if not rule.low <= rule.high:
                raise ValueError(f"Feature rule {i + 1}: Low = {rule.low:g} is above High = "
                                 f"{rule.high:g}: a range needs Low <= High")
            lo, hi = [-OPEN] * len(FEATURES), [OPEN] * len(FEATURES)
            k = FEATURES.index(rule.feature)
            lo[k], hi[k] = rule.low, rule.high
            rules.append((rule.texture, lo, hi))
        inputs["rules"] = rules
        return params, inputs

    @classmethod
    def _inflows(cls, context, settings, taps, fp, frames, lo, hi):
        """The core's inflow, inflow_velocity and inflow_normal of the objects ``taps`` (the
        Inflow and those of the Inflows collection): as they are for one, lists of one per
        tap for several. Each pours from its own shape (_flow) at the Inflow Velocity (turned
        by its own axes with Local Velocity, with Source its own motion added); a flat sheet's
        Normal goes into its velocity, along its faces' normal."""
        shapes, velocities, normals = [], [], []
        normal = None  # (the Normal, read once for all the taps that spray it)
        for obj in taps:
            made = {}
            shapes.append((yield from cls._flow(context, settings, "Inflow", obj, fp, frames, lo,
                                                hi, made)))
            sheet = made.get("shape")
            sheet = sheet if sheet is not None and sheet.sheet else None
            # a flat sheet's Normal is one velocity, along its faces' normal (as Mantaflow's
            # planar flow): poured from its lattice, one side only
            flat = sheet.flat if sheet is not None and not animation.may_deform(obj) else None
            velocities.append((yield from cls._inflow_velocity(context, settings, obj, frames,
                                                               fp["dt"], flat)))
            if flat is not None:
                normals.append(0.0)
                continue
            if normal is None:
                normal = yield from cls._inflow_normal(context, settings, frames)
            normals.append(normal)
            if sheet is not None and _sprays(normal):
                warnings.warn(f"Inflow: {obj.name}'s faces are open and do not lie in one "
                              "plane facing one way, so its Normal sprays from both sides of "
                              "them; flatten it for one side, or close it for a sprinkler",
                              BakeWarning)
        sprays = any(map(_sprays, normals))
        if len(taps) == 1:
            return {"inflow": shapes[0], "inflow_velocity": velocities[0],
                    **({"inflow_normal": normals[0]} if sprays else {})}
        return {"inflow": shapes, "inflow_velocity": velocities,
                **({"inflow_normal": normals} if sprays else {})}

    @staticmethod
    def _followed_shape(context, obj, role, fp, frames, lo, hi, made):
        """(the shape at the bake's first frame, {frame: shape} where it moves or changes
        shape after) of the Inflow or Outflow object, as the Fill's (a ball, a field, a
        sheet, or its box clipped to the domain); None at frames it is outside the domain.
        Refused if it is outside at every frame. ``made`` is _fill_shape's."""
        holder = meshes.shape_holder(obj)
        spacing = fp["particle_spacing"]

        def shape(_dg):
            got = _fill_shape(context, holder, spacing, role, made)
            flo, fhi = meshes.world_bounds(holder)
            if got is not None and getattr(made.get("shape"), "sheet", None):
                flo, fhi = flo - made["shape"].sheet, fhi + made["shape"].sheet  # (a plane)
            flo, fhi = np.maximum(flo, lo), np.minimum(fhi, hi)
            if np.any(fhi - flo < spacing):
                return None  # out of the box at this frame: it does nothing there
            if got is None:
                got = ("box", tuple(map(float, (flo + fhi) / 2)),
                       tuple(map(float, (fhi - flo) / 2)))
            return got
        first, path = yield from animation.followed(context, holder, frames, shape,
                                                    same=_same_shape)
        if first is None and all(sh is None for sh in path.values()):
            raise ValueError(f"{role}: {obj.name!r} must overlap the domain's box by at least "
                             f"particle_spacing = {spacing:g} m on every axis (at some frame "
                             "of the bake)")
        return first, path

    @classmethod
    def _flow(cls, context, settings, role, obj, fp, frames, lo, hi, made=None):
        """The core's inflow or outflow schedule of ``obj`` (``role`` "Inflow" or "Outflow"),
        {frame: shape or None}: None before its Start and after its End; in between its shape
        (as the Fill's: a ball, a field, a sheet, or its box) at the start and wherever it
        moves or changes shape after (None where it is outside the domain)."""
        key = role.lower()
        start, end = getattr(settings, f"{key}_start"), getattr(settings, f"{key}_end")
        if end < start:
            raise ValueError(f"{role} End = {end} is before {role} Start = {start}: the "
                             f"{role} would never {'pour' if key == 'inflow' else 'drain'}")
        first, path = yield from cls._followed_shape(context, obj, role, fp, frames, lo, hi,
                                                     {} if made is None else made)
        out = {frames[0]: None} if start > frames[0] else {}
        if start <= frames[1] and end >= frames[0]:
            on = max(start, frames[0])
            out[on] = first
            for f in sorted(path):  # (the shape a later start begins with, then its moves)
                if f <= on:
                    out[on] = path[f]
                elif f <= end:
                    out[f] = path[f]
            if end < frames[1]:
                out[end + 1] = None
        return out

    @classmethod
    def _fill_velocity(cls, context, settings, fill, frames, dt):
        """The Fill's water's velocity at the start: the Initial Velocity plus Source times the
        Fill object's own velocity over the first frame (its world position there, to the
        next frame's)."""
        got = yield from cls._followed_velocity(
            context, settings, "fill_velocity", fill,
            (frames[0], min(frames[0] + 1, frames[1])), dt, False, settings.fill_source)
        return got[frames[0]] if isinstance(got, dict) else got

    @classmethod
    def _inflow_velocity(cls, context, settings, obj, frames, dt, flat=None):
        """The core's inflow_velocity: the Inflow Velocity (world axes; with Local Velocity
        turned by the Inflow object's world rotation) plus Source times the object's own
        velocity (see _followed_velocity); for a flat sheet plus Normal times its faces'
        normal (``flat``, in its scaled own axes) turned into the world."""
        return (yield from cls._followed_velocity(
            context, settings, "inflow_velocity", obj, frames, dt,
            settings.inflow_local, settings.inflow_source, flat))

    @staticmethod
    def _inflow_normal(context, settings, frames):
        """The core's inflow_normal: the Normal, or {frame: Normal} at the first frame and
        wherever it changes after, where it is keyed or driven (a sprinkler turned up)."""
        if not animation.property_animated(settings, "inflow_normal"):
            return float(settings.inflow_normal)
        first, path = yield from animation.followed(
            context, settings.id_data, frames, lambda _dg: float(settings.inflow_normal),
            same=float.__eq__, animated=True)
        return {frames[0]: first, **path} if path else first

    @staticmethod
    def _followed_velocity(context, settings, name, obj, frames, dt, local, source,
                           along=None):
        """The velocity property ``name`` of ``settings`` (turned by ``obj``'s world rotation
        if ``local``) plus ``source`` times obj's own velocity over each frame's step (the
        frame before to it; the first frame takes the second's), plus the Inflow's Normal
        times ``along`` (a direction in obj's scaled own axes) turned into the world, over
        ``frames``: one velocity when that is the same at every frame, else {frame:
        velocity} at the first frame and wherever it changes after. A keyed or driven
        property is read at each frame (a tap turned up)."""
        keyed = animation.property_animated(settings, name) or (
            along is not None and animation.property_animated(settings, "inflow_normal"))
        if not local and not source and not keyed and (along is None or
                                                         not settings.inflow_normal):
            return tuple(map(float, getattr(settings, name)))

        def read(_dg):  # (its rotation alone turns it: a scale does not change the speed)
            m, v = obj.matrix_world, mathutils.Vector(getattr(settings, name))
            v = m.to_quaternion() @ v if local else v
            if along is not None and settings.inflow_normal:
                axes = meshes.own_axes(m)
                turn = axes[0] if axes is not None else np.array(m.to_quaternion().to_matrix())
                v = v + mathutils.Vector(turn @ along) * settings.inflow_normal
            return (tuple(v), tuple(m.translation) if source else ())
        first, path = yield from animation.followed(context, obj, frames, read, same=tuple.__eq__,
                                                    animated=keyed)
        at = {frames[0]: first}
        for f in range(frames[0] + 1, frames[1] + 1):
            at[f] = path.get(f, at[f - 1])

        def moved(f):  # (m/s over the step into f; the first frame's is the second's)
            g = max(f, frames[0] + 1)
            return (np.subtract(at[g][1], at[g - 1][1]) * (source / dt) if source and g in at
                    else 0.0)
        got = {f: tuple(map(float, np.add(at[f][0], moved(f)))) for f in at}
        keep = {f: got[f] for f in got if f == frames[0] or got[f] != got[f - 1]}
        return keep[frames[0]] if len(keep) == 1 else keep

    @staticmethod
    def _mantaflow(context, obj, settings, fp, frames):
        """The VELOCITY_GRID source from a baked Mantaflow liquid domain: velocity read per
        frame from its cache (no bpy needed then), the surface from its liquid mesh, sampled
        here (Blender owns the mesh) as crossings of the vertex columns."""
        dom = settings.liquid_domain or obj
        mod = next((m for m in dom.modifiers
                    if m.type == "FLUID" and m.fluid_type == "DOMAIN"), None)
        if mod is None:
            raise ValueError(f"Liquid Domain: {dom.name} has no Fluid modifier of type Domain "
                             "(VELOCITY_GRID reads a baked Mantaflow liquid)")
        d = mod.domain_settings
        if d.domain_type != "LIQUID":
            raise ValueError(f"Liquid Domain: {dom.name} is a {d.domain_type.lower()} domain; "
                             "only liquid domains are supported")
        if d.cache_data_format != "OPENVDB":
            raise ValueError(f"Liquid Domain: {dom.name}'s cache format is "
                             f"{d.cache_data_format}; set Cache > Data to OpenVDB and re-bake")
        if d.use_adaptive_domain:
            raise ValueError(f"Liquid Domain: {dom.name} uses an adaptive domain; turn it off "
                             "and re-bake (the cache must span the whole domain)")
        cache = bpy.path.abspath(d.cache_directory)
        missing = [f for f in range(frames[0], frames[1] + 1)
                   if not os.path.isfile(mantaflow.data_path(cache, f))]
        if missing:
            raise ValueError(f"Liquid Domain: {dom.name}'s cache {cache} has no data for "
                             f"frames {missing[0]}..{missing[-1]}: bake the liquid first")
        # Mantaflow's grid spans the domain mesh's own box, along the object's axes: the
        # velocity is sampled there and turned into the world (a domain turned about z).
        meshes.data_world_bounds(dom)  # refuses a mesh without vertices, by name
        co = np.empty(len(dom.data.vertices) * 3, np.float64)
        dom.data.vertices.foreach_get("co", co)
        dlo, dhi = co.reshape(-1, 3).min(axis=0), co.reshape(-1, 3).max(axis=0)
        matrix = np.array(dom.matrix_world, np.float64)
        res = fp["resolution"]
        lo, hi = np.array(fp["box_min"]), np.array(fp["box_max"])
        surfaces = None
        if d.use_mesh:
            xs = np.linspace(lo[0], hi[0], res[0] + 1)
            ys = np.linspace(lo[1], hi[1], res[1] + 1)
            surfaces = yield from animation.per_frame(
                context.scene, frames[0], frames[1], lambda f: meshes.z_crossings(
                    dom, xs, ys, lo[2], hi[2], evaluated_depsgraph(context),
                    role="Liquid Domain"))
        else:
            warnings.warn(f"Liquid Domain: {dom.name} has Mesh off, so there is no liquid "
                          "surface: the textured fluid stays empty and the grids fill the whole "
                          "domain; turn on Mesh in its Fluid settings and bake it", BakeWarning)
        fp["surface_threshold"] = 0.5  # the crossings' field is 0.5 on the liquid surface
        return mantaflow.CacheSource(cache, range(frames[0], frames[1] + 1), dlo, dhi, lo, hi,
                                     res, surfaces, d.time_scale, matrix)

    @staticmethod
    def _obstacles(context, found, frames, spacing):
        """The obstacles at the first frame, and {frame: all of them} for the later frames
        where one that is animated, constrained or deformed stands otherwise than the frame
        before (the fluid meets it moving there). A round mesh (a ball) is a sphere, decided
        at the first frame; any other mesh is its shape as a distance field (mesh_fields),
        made at the first frame and carried with the object; so is a curve, surface, text or
        metaball family (found holds its basis), as the mesh Blender evaluates it to. A mesh
        whose shape changes gets a field at every frame over that frame's shape, all of one
        count of points (coarser: DEFORMING_SIDE along the longest side), so that the step
        changes each into the next and the water meets its surface moving. A box-shaped mesh
        and an object without faces (an empty, a curve without bevel) are their own bounding
        box, turned with them (a box in the world's axes when turned at no frame)."""
        deforming = {k for k, o in enumerate(found) if animation.may_deform(o)}
        movers = {k for k, o in enumerate(found) if animation.may_move(o)} | deforming
        dg = evaluated_depsgraph(context)
        round_ = [_round(o, dg) for o in found]
        meshes_ = [k for k, o in enumerate(found)
                   if round_[k] is None and o.type in animation.SHAPED_TYPES]
        shapes = [None] * len(found)
        # a deforming mesh: its sample and world matrix at each frame, made fields at the end
        samples = {}
        for k in (k for k in meshes_ if k in deforming):
            ev = evaluated_object(found[k], dg, "Obstacles")
            sample = mesh_fields.mesh_sample(ev) \
                if meshes.own_axes(ev.matrix_world) is not None else None
            if sample is not None:
                samples[k] = [(sample, ev.matrix_world.copy())]
        rigid = [k for k in meshes_ if k not in deforming]
        for n, k in enumerate(rigid):  # (a field takes up to a second: a step of its own)
            shapes[k] = mesh_fields.mesh_shape(evaluated_object(found[k], dg, "Obstacles"),
                                               spacing)
            if shapes[k] is not None and not shapes[k].signed:
                _warn_unsigned(found[k])
            yield f"the shape of {found[k].name}", n + 1, len(rigid)

        def obstacles(_f=None):
            graph = evaluated_depsgraph(context) if _f is not None else dg
            out = []
            for k, o in enumerate(found):
                # what moves: its evaluated shape and place at this frame (refused by name if
                # the view layer does not evaluate it); a still one as before
                ev = evaluated_object(o, graph, "Obstacles") if k in movers else o
                olo, ohi = meshes.world_bounds(ev)
                if round_[k] is not None:
                    # (a ball that stops being round is the sphere around its box's centre)
                    ball = _round(o, graph) if k in movers else round_[k]
                    out.append(("sphere",) + (ball or (tuple(map(float, (olo + ohi) / 2)),
                                                       float(np.max(ohi - olo) / 2))))
                    continue
                if k in samples:
                    if _f is not None:  # (a shape it cannot have, flat or box-like: the last)
                        samples[k].append((mesh_fields.mesh_sample(ev) or samples[k][-1][0],
                                           ev.matrix_world.copy()))
                    out.append(None)  # its field comes once every frame's shape is known
                    continue
                if shapes[k] is not None:
                    out.append(shapes[k].placed(ev.matrix_world, _f is None))
                    continue
                turned = meshes.turned_bounds(ev)
                out.append(("turned_box",) + turned if turned else
                           ("box", tuple(map(float, (olo + ohi) / 2)),
                            tuple(map(float, (ohi - olo) / 2))))
            return out
        first = obstacles()
        got = {}
        if movers and frames[1] > frames[0]:
            got = yield from animation.per_frame(context.scene, frames[0] + 1, frames[1],
                                                 obstacles)
        every = [first] + list(got.values())
        for n, (k, taken) in enumerate(samples.items()):
            scaled = [(sample, mesh_fields.scale_of(m)) for sample, m in taken]
            boxes = mesh_fields.field_boxes(scaled, spacing, DEFORMING_SIDE)
            unsigned = False
            for i, ((sample, scale), (_, matrix)) in enumerate(zip(scaled, taken)):
                shape = mesh_fields.shape_in(sample, scale, boxes[i])
                unsigned |= not shape.signed
                every[i][k] = shape.placed(matrix, True)
                yield f"the shape of {found[k].name}, frame {frames[0] + i}", \
                    n * len(taken) + i + 1, len(samples) * len(taken)
            if unsigned:
                _warn_unsigned(found[k])
        # One kind per obstacle for the whole bake: a box turned at some frame is a turned
        # box at all of them (unturned: the identity).
        for k in range(len(found)):
            if any(obs[k][0] == "turned_box" for obs in every):
                for obs in every:
                    if obs[k][0] == "box":
                        obs[k] = ("turned_box",) + obs[k][1:] + ((1.0, 0.0, 0.0, 0.0),)
        # A frame is kept where an obstacle stands otherwise or a mesh has another shape.
        held = {}  # obstacle: the digest of the field it has then

        def state(obs):
            for k, ob in enumerate(obs):
                if ob[0] == "mesh" and ob[4] is not None:
                    held[k] = hashlib.sha256(ob[4].tobytes()).hexdigest()
            return [ob[:4] + (held.get(k),) for k, ob in enumerate(obs)]
        path, last = {}, state(first)
        for f, here in got.items():
            now = state(here)
            if now != last:
                path[f], last = here, now
        return first, path

    @staticmethod
    def _particles(context, pobj, frames, lo, hi):
        def particles(_f):
            ev = evaluated_object(pobj, evaluated_depsgraph(context), "Particles")
            if not ev.particle_systems:
                raise ValueError(f"Particles: {pobj.name} has no particle system")
            ps = ev.particle_systems[0].particles
            n = len(ps)
            pos, vel = np.empty(n * 3, np.float32), np.empty(n * 3, np.float32)
            alive = np.empty(n, np.int32)
            ps.foreach_get("location", pos)
            ps.foreach_get("velocity", vel)
            ps.foreach_get("alive_state", alive)
            keep_mask = alive == 3  # ALIVE
            pos, vel = pos.reshape(-1, 3)[keep_mask], vel.reshape(-1, 3)[keep_mask]
            inside = np.all((pos >= lo) & (pos <= hi), axis=1)  # the box holds the fluid
            return pos[inside], vel[inside]
        return (yield from animation.per_frame(context.scene, frames[0], frames[1], particles))

    @classmethod
    def apply(cls, context, obj, settings, folder, manifest):
        frames = sorted(int(f) for f in manifest["frames"])
        coll = obj.users_collection[0] if obj.users_collection else None
        # A re-bake reuses the objects it made, renamed by the artist or not (a new pair by
        # the default names would be made otherwise).
        old_surf, old_vol = cls._wired(obj, settings, folder)
        vol_name = old_vol.name if old_vol is not None else f"HBK_{obj.name}_volume"
        new_vol = old_vol is None and bpy.data.objects.get(vol_name) is None
        vol = volumes.load_volume_sequence(folder, "fluid", frames[0], len(frames), vol_name,
                                           collection=coll)
        if new_vol:
            # The grids are for shading and for other tools; the render shows the textured
            # surface (enable the volume in renders to see the density as fog; a re-bake
            # keeps that choice).
            vol.hide_render = True
            vol.display_type = "BOUNDS"
        fp = manifest["params"]["fluid"]
        groups = [("VOXEL" if sm.voxel_file else sm.group) for sm in settings.samples]
        mat = cls._material(f"HBK_{obj.name}_textured", fp["textures"],
                            fp["texture_scale"], groups)
        vmat = cls._material(f"HBK_{obj.name}_volume", fp["textures"], fp["texture_scale"],
                             groups, volume=True)
        vol.data.materials.clear()
        vol.data.materials.append(vmat)
        surf_name = old_surf.name if old_surf is not None else f"HBK_{obj.name}_surface"
        surf = frame_meshes.attach(surf_name, "surface", folder, "surface",
                                   collection=coll, material=mat)
        surf["hydrobake_domain"] = obj.name  # for Capture Feature Rule
        helper_objects.tag(surf, "fluid", obj.name, "surface")
        helper_objects.tag(vol, "fluid", obj.name, "volume")
        # The domain is only a box: show the fluid, not the box (Free Bake shows it again as
        # it was: the first bake's view is kept through re-bakes).
        if SHOWN not in settings:
            settings[SHOWN] = {"display": obj.display_type, "hidden": int(obj.hide_render)}
        obj.display_type = "BOUNDS"
        obj.hide_render = True

    @classmethod
    def _wired(cls, obj, settings, folder=None):
        """(surface, Volume object) that apply made for the bake, or None each: by the names
        apply gave them, else (renamed by the artist since) by their tag, else (renamed, made
        before objects were tagged) the ones showing the files in ``folder`` (default: the
        recorded one)."""
        folder = folder or settings.bake_folder
        top = os.path.join(os.path.realpath(bpy.path.abspath(folder)), "") if folder else None

        def shows(path):
            return bool(top and path) and os.path.join(
                os.path.realpath(bpy.path.abspath(path)), "").startswith(top)

        found = []
        for kind, suffix in (("MESH", "surface"), ("VOLUME", "volume")):
            named = helper_objects.find("fluid", cls.baked_name(obj, settings), suffix, kind)
            if named is not None:
                found.append(named)
                continue
            found.append(next((
                o for o in bpy.data.objects if o.type == kind and o.library is None and (
                    shows(o.data.filepath) if kind == "VOLUME" else
                    "hydrobake_domain" in o and
                    shows(frame_meshes.folder_of(o)))), None))
        return tuple(found)

    @staticmethod
    def _material(name, count, scales, groups, volume=False):
        """The textured fluid's material, rebuilt when what it samples changes: sample texture
        k (its node group, or a built-in noise, waves or cells) at the advected uvw times its
        scale, cross-faded between fields A and B by uvw_weight, tinted, and summed with the
        baked blend weights (they sum to one, so the sum is the blend). The surface reads the
        mesh's attributes; ``volume``: the Volume's shader reads the same grids (uvw_unwrapped,
        uvw_b_unwrapped, uvw_weight, blend_k; density for the fog), voxel textures falling back
        to built-ins as Cycles cannot sample 3D images."""
        # Kept as it is while what it samples is the same: an artist's edits (roughness,
        # transmission, colour) survive a re-bake.
        sig = repr((count, [float(x) for x in scales[:count]],
                    [g if isinstance(g, str) or g is None else g.name for g in groups], volume,
                    "eevee preview"))
        mat = bpy.data.materials.get(name)
        if mat is not None and mat.get("hydrobake_signature") == sig and mat.node_tree:
            return mat
        mat = mat or bpy.data.materials.new(name)
        mat["hydrobake_signature"] = sig
        mat.use_nodes = True
        tree = mat.node_tree
        tree.nodes.clear()
        out_node = tree.nodes.new("ShaderNodeOutputMaterial")
        out_node.location = (900, 0)
        if volume:
            bsdf = tree.nodes.new("ShaderNodeVolumePrincipled")
            bsdf.location = (600, 0)
            tree.links.new(bsdf.outputs["Volume"], out_node.inputs["Volume"])
            dens = tree.nodes.new("ShaderNodeAttribute")
            dens.attribute_name, dens.location = "density", (100, -300)
            scale = tree.nodes.new("ShaderNodeMath")
            scale.operation, scale.location = "MULTIPLY", (350, -300)
            scale.inputs[1].default_value = 0.02  # per kg/m^3: water (1000) is a thick fog
            tree.links.new(dens.outputs["Fac"], scale.inputs[0])
            tree.links.new(scale.outputs["Value"], bsdf.inputs["Density"])
            groups = [None if g == "VOXEL" else g for g in groups]
        else:
            bsdf = tree.nodes.new("ShaderNodeBsdfPrincipled")
            bsdf.location = (600, 0)
            bsdf.inputs["Roughness"].default_value = 0.25
            tree.links.new(bsdf.outputs["BSDF"], out_node.inputs["Surface"])

        def attr(name, x, y, kind="Vector"):
            n = tree.nodes.new("ShaderNodeAttribute")
            n.attribute_name, n.location = name, (x, y)
            return n.outputs[kind]

        def node(idname, x, y, **inputs):
            n = tree.nodes.new(idname)
            n.location = (x, y)
            for key, value in inputs.items():
                n.inputs[key].default_value = value
            return n

        def sample(k, uvw, x, y, plain):
            group = groups[k] if k < len(groups) else None
            if group == "VOXEL":  # sampled per vertex by the bake, already cross-faded
                return attr(f"sample_{k}", x, y, "Color")
            if group is not None:
                t = node("ShaderNodeGroup", x, y)
                t.node_tree = group
                tree.links.new(uvw, t.inputs[_group_socket(group, "INPUT")])
                return t.outputs[_group_socket(group, "OUTPUT")]
            kind = ("noise", "wave", "voronoi")[k % 3]
            if plain:  # the plain texture: in a volume (eight copies per step of a volume ray
                # cost minutes), at uvw unwrapped near the rest mapping, so no tile seams
                # where the fluid moved less than half a tile; in EEVEE's preview
                idname, settings = tileable.KINDS[kind]
                t = node(idname, x, y, **settings)
            else:  # Blender's own textures do not repeat: wrapped in a tileable group
                t = node("ShaderNodeGroup", x, y)
                t.node_tree = tileable.group(kind)
            tree.links.new(uvw, t.inputs["Vector"])
            return t.outputs["Color"]

        # The Volume reads the unwrapped grids: Cycles interpolates them without wrap flags.
        fields = ("uvw_unwrapped", "uvw_b_unwrapped") if volume else ("uvw_a", "uvw_b")
        ua, ub = attr(fields[0], -1600, 200), attr(fields[1], -1600, -100)
        w = attr("uvw_weight", -1600, 400, "Fac")
        tints = ((0.15, 0.45, 0.9, 1), (0.95, 0.97, 1.0, 1), (1.0, 0.45, 0.1, 1),
                 (0.3, 0.8, 0.35, 1), (0.8, 0.3, 0.75, 1), (0.9, 0.85, 0.3, 1),
                 (0.4, 0.4, 0.45, 1), (0.3, 0.8, 0.8, 1))
        def blend(plain, y0):
            """The sample textures summed by their blend weights (laid out from y0)."""
            total = None
            for k in range(int(count)):
                y = y0 + 600 - 320 * k
                scaled = []
                for field, dy in ((ua, 0), (ub, -140)):
                    sc = node("ShaderNodeVectorMath", -1350, y + dy)
                    sc.operation = "SCALE"
                    sc.inputs["Scale"].default_value = float(scales[k])
                    tree.links.new(field, sc.inputs[0])
                    scaled.append(sc.outputs["Vector"])
                a = sample(k, scaled[0], -1100, y, plain)
                b = sample(k, scaled[1], -1100, y - 140, plain)
                fade = node("ShaderNodeMixRGB", -850, y)  # fac = weight of A
                tree.links.new(w, fade.inputs["Fac"])
                tree.links.new(b, fade.inputs["Color1"])
                tree.links.new(a, fade.inputs["Color2"])
                colour = fade.outputs["Color"]
                if k >= len(groups) or groups[k] is None:  # a built-in: give it its own colour
                    tint = node("ShaderNodeMixRGB", -650, y, Fac=1.0, Color2=tints[k % len(tints)])
                    tint.blend_type = "MULTIPLY"
                    tree.links.new(colour, tint.inputs["Color1"])
                    colour = tint.outputs["Color"]
                part = node("ShaderNodeVectorMath", -400, y)
                part.operation = "SCALE"
                tree.links.new(colour, part.inputs[0])
                tree.links.new(attr(f"blend_{k}", -650, y + 120, "Fac"), part.inputs["Scale"])
                if total is None:
                    total = part.outputs["Vector"]
                else:
                    add = node("ShaderNodeVectorMath", -150, y + 60)
                    add.operation = "ADD"
                    tree.links.new(total, add.inputs[0])
                    tree.links.new(part.outputs["Vector"], add.inputs[1])
                    total = add.outputs["Vector"]
            return total

        tree.links.new(blend(volume, 0), bsdf.inputs["Color" if volume else "Base Color"])
        if not volume:
            # EEVEE (the viewport's Material Preview, playback) gets the plain textures: the
            # tileable groups' eight evaluations per texture and field made a shader that took
            # minutes to compile without a GPU. Tile seams may show there, never in Cycles.
            out_node.target = "CYCLES"
            preview_out = node("ShaderNodeOutputMaterial", 900, -2900)
            preview_out.target = "EEVEE"
            preview = node("ShaderNodeBsdfPrincipled", 600, -2900, Roughness=0.25)
            preview.label = "EEVEE preview"
            tree.links.new(preview.outputs["BSDF"], preview_out.inputs["Surface"])
            tree.links.new(blend(True, -3000), preview.inputs["Base Color"])
        return mat

    @classmethod
    def let_go(cls, context, obj, settings, keep):
        cls._show_again(obj, settings)

    @staticmethod
    def _show_again(obj, settings):
        """The domain as it was shown before its first bake (TEXTURED and rendered for a bake
        recorded before that was kept)."""
        shown = settings.get(SHOWN) or {"display": "TEXTURED", "hidden": 0}
        obj.display_type, obj.hide_render = shown["display"], bool(shown["hidden"])
        if SHOWN in settings:
            del settings[SHOWN]

    @classmethod
    def remove(cls, context, obj, settings):
        name = cls.baked_name(obj, settings)
        surf, vol = cls._wired(obj, settings)
        # (with any Shift+D copy of them: they show the files this Free removes)
        for o in ({surf} | set(helper_objects.every("fluid", name, "surface", "MESH"))) - {None}:
            frame_meshes.detach(o.name)
        for o in ({vol} | set(helper_objects.every("fluid", name, "volume", "VOLUME"))) - {None}:
            data = o.data
            bpy.data.objects.remove(o)
            if data.users == 0:
                bpy.data.volumes.remove(data)
        # The textured materials stay, unused, for the session: a re-bake sampling the same
        # textures takes them up again with the artist's edits (a save drops them if not).
        cls._show_again(obj, settings)

    @classmethod
    def register_extra(cls):
        frame_meshes.ensure_handler()
        for c in (*fluid_paint.CLASSES, HYDROBAKE_OT_fluid_sample,
                  HYDROBAKE_OT_fluid_noise_texture):
            bpy.utils.register_class(c)
        bpy.types.Object.hydrobake_fluid_paint = bpy.props.PointerProperty(
            type=fluid_paint.HYDROBAKE_PG_fluid_paint)

    @classmethod
    def unregister_extra(cls):
        frame_meshes.unregister()
        del bpy.types.Object.hydrobake_fluid_paint
        for c in (HYDROBAKE_OT_fluid_noise_texture, HYDROBAKE_OT_fluid_sample,
                  *reversed(fluid_paint.CLASSES)):
            bpy.utils.unregister_class(c)

    @staticmethod
    def extra_classes():
        """Registered before the settings, which hold rules and samples of these types."""
        return (HYDROBAKE_PG_fluid_rule, HYDROBAKE_PG_fluid_sample)

    @classmethod
    def derived(cls, settings):
        """{"fluid.name": why} of the parameters prepare sets itself (drawn inactive, refused
        as command-line overrides): set in the panel they would do nothing."""
        box = "the domain object's box sets it; move or scale the domain"
        out = {"fluid.box_min": box, "fluid.box_max": box,
               "fluid.dt": "the scene's frame rate sets it",
               "fluid.texture_feature": "Capture Feature Rule sets it for the rule it makes",
               "fluid.seed": "only a jittered fill reads it, and Blender fills a lattice"}
        if settings.fluid.source == "VELOCITY_GRID":
            out["fluid.surface_threshold"] = "the liquid mesh's crossings set it (0.5)"
        return out

    @classmethod
    def draw_settings(cls, layout, settings):
        col = layout.column()
        for name in ("fill_object", "fill_velocity", "fill_source", "inflow_object",
                     "inflow_collection"):
            col.prop(settings, name)
        if settings.inflow_object is not None or settings.inflow_collection is not None:
            sub = col.column(align=True)
            sub.prop(settings, "inflow_velocity")
            sub.prop(settings, "inflow_normal")
            sub.prop(settings, "inflow_local")
            sub.prop(settings, "inflow_source")
            row = sub.row(align=True)
            row.prop(settings, "inflow_start", text="Start")
            row.prop(settings, "inflow_end", text="End")
        col.prop(settings, "outflow_object")
        col.prop(settings, "outflow_collection")
        if settings.outflow_object is not None or settings.outflow_collection is not None:
            row = col.row(align=True)
            row.prop(settings, "outflow_start", text="Start")
            row.prop(settings, "outflow_end", text="End")
        for name in ("particle_object", "liquid_domain", "obstacles", "paint_collection"):
            col.prop(settings, name)
        box = col.box()
        box.label(text=f"Feature rules: {len(settings.rules)}")
        for rule in settings.rules:
            row = box.row(align=True)
            row.prop(rule, "texture", text="")
            row.prop(rule, "feature", text="")
            row.prop(rule, "low", text="")
            row.prop(rule, "high", text="")
        box.operator("hydrobake.fluid_capture_rule", icon="EYEDROPPER")
        box = col.box()
        box.label(text=f"Sample textures: {settings.fluid.textures} (node groups: "
                       f"{len(settings.samples)})")
        for k, sm in enumerate(settings.samples):
            sub = box.column(align=True)
            sub.prop(sm, "group", text=f"Texture {k}")
            row = sub.row(align=True)
            row.prop(sm, "voxel_file", text="Voxel")
            op = row.operator("hydrobake.fluid_noise_texture", text="", icon="TEXTURE")
            op.index = k
        row = box.row(align=True)
        row.operator("hydrobake.fluid_sample", text="Add", icon="ADD").action = "ADD"
        row.operator("hydrobake.fluid_sample", text="Remove", icon="REMOVE").action = "REMOVE"
        super().draw_settings(layout, settings)
