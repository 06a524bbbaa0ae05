"""Painting the fluid from Blender (paper §3.1): strokes (Empties, or point meshes captured
from the baked surface) in the domain's paint collection, and the operators that capture a
local paint or a feature rule from a selection, weights or colours painted on the surface."""
import os

import bpy
import numpy as np

from ...core import fluid as core_fluid
from ..bridge import frame_meshes, meshes

FEATURES = tuple(f.upper() for f in core_fluid.FEATURES)  # enum items: DENSITY, ...


class HYDROBAKE_PG_fluid_paint(bpy.types.PropertyGroup):
    """A stroke that paints a sample texture into the fluid: an Empty (a ball) or a mesh (a
    ball around each vertex, its "coverage" attribute the strength)."""
    enabled: bpy.props.BoolProperty(
        name="Paint Fluid", default=False,
        description="Paint a texture into the fluid where this object is, at its frame; the "
                    "paint flows with the fluid and fades (Paint Duration, Paint Fade)")
    texture: bpy.props.IntProperty(name="Texture", default=1, min=0, max=7,
                                   description="Sample texture painted (0-based)")
    frame: bpy.props.IntProperty(name="Frame", default=1, min=0, max=1048574,
                                 description="Frame at which the stroke is applied")
    reach: bpy.props.FloatProperty(
        name="Reach", default=0.03, min=0.0, soft_max=0.5, unit="LENGTH",
        description="A mesh stroke: how far around each vertex the paint goes at full "
                    "strength (it then fades over half as far again); at most 16 voxels")


class HYDROBAKE_PT_fluid_paint(bpy.types.Panel):
    bl_label = "Hydrobake Fluid Paint"
    bl_space_type, bl_region_type, bl_context = "PROPERTIES", "WINDOW", "object"
    bl_options = {"DEFAULT_CLOSED"}

    @classmethod
    def poll(cls, context):
        obj = context.object
        return obj is not None and (obj.type == "EMPTY" or (
            obj.type == "MESH" and obj.hydrobake_fluid_paint.enabled))

    def draw(self, context):
        obj = context.object
        p = obj.hydrobake_fluid_paint
        col = self.layout.column()
        col.use_property_split = True
        col.prop(p, "enabled")
        sub = col.column()
        sub.active = p.enabled
        sub.prop(p, "texture")
        sub.prop(p, "frame")
        if obj.type == "MESH":
            sub.prop(p, "reach")
        else:
            col.label(text="Radius: the empty's display size x scale")


class HYDROBAKE_PT_fluid_surface(bpy.types.Panel):
    """On the baked surface: capture what was painted or selected on it."""
    bl_label = "Hydrobake Fluid Surface"
    bl_space_type, bl_region_type, bl_context = "PROPERTIES", "WINDOW", "object"

    @classmethod
    def poll(cls, context):
        return context.object is not None and "hydrobake_domain" in context.object

    def draw(self, context):
        col = self.layout.column()
        domain = domain_of(context.object)
        name = domain.name if domain is not None else context.object["hydrobake_domain"]
        col.label(text=f"Baked from {name}, frame {context.scene.frame_current}")
        col.operator("hydrobake.fluid_capture_paint", icon="BRUSH_DATA")
        col.operator("hydrobake.fluid_capture_rule", icon="EYEDROPPER")


def _on_surface(_cls, context):
    """The capture buttons: active only on a baked surface."""
    return context.object is not None and "hydrobake_domain" in context.object


def _surface_folder(surf):
    """The bake folder whose surface sequence ``surf`` shows (real path), or None."""
    folder = frame_meshes.folder_of(surf)
    return os.path.realpath(folder) if folder else None


def domain_of(surf):
    """The domain whose bake the surface ``surf`` shows, or None. Found by the bake's folder
    (the surface's sequence): the domain may have been renamed since its bake, and the name
    the surface recorded then is no object's now (or another's). Of several objects recording
    that bake (Shift+D copies), the one with the recorded name, else the one it was baked
    under; without a folder, by the recorded name."""
    name = surf.get("hydrobake_domain", "")
    folder = _surface_folder(surf)
    holders = [o for o in bpy.data.objects
               if folder and o.hydrobake_fluid.is_baked and o.hydrobake_fluid.bake_folder and
               os.path.realpath(o.hydrobake_fluid.bake_folder) == folder]
    for pick in (lambda o: o.name == name, lambda o: o.hydrobake_fluid.get("baked_as") == name):
        hit = [o for o in holders if pick(o)]
        if hit:
            return hit[0]
    if holders:
        return holders[0]
    return bpy.data.objects.get(name) if name else None


def _surface_and_domain(op, context):
    """The active baked surface and its domain, or (None, None) after reporting why not."""
    surf = context.object
    domain = domain_of(surf) if surf else None
    if domain is None:
        op.report({"ERROR"}, "Select the baked fluid surface (HBK_<domain>_surface)")
        return None, None
    ntex = domain.hydrobake_fluid.fluid.textures
    if op.texture >= ntex:
        op.report({"ERROR"}, f"Texture = {op.texture}: must be < textures = {ntex}")
        return None, None
    if surf.mode == "EDIT":
        bpy.ops.object.mode_set(mode="OBJECT")  # writes the edit-mode selection back
    return surf, domain


def _dialog(op, context, _event):
    """From a button: ask for the texture and the source first (a script's call runs
    execute with its arguments directly)."""
    return context.window_manager.invoke_props_dialog(op)


def _selection(mesh):
    sel = np.zeros(len(mesh.vertices), bool)
    mesh.vertices.foreach_get("select", sel)
    return sel


def _weights(obj):
    """The active vertex group's weight per vertex (0 outside the group), or None."""
    group = obj.vertex_groups.active
    if group is None:
        return None
    w = np.zeros(len(obj.data.vertices), np.float32)
    for v in obj.data.vertices:
        for g in v.groups:
            if g.group == group.index:
                w[v.index] = g.weight
    return w


def _colours(mesh):
    """The active colour attribute's brightness (mean of RGB) per vertex, or None."""
    attr = mesh.color_attributes.active_color if len(mesh.color_attributes) else None
    if attr is None:
        return None
    rgba = np.empty(len(attr.data) * 4, np.float32)
    attr.data.foreach_get("color", rgba)
    value = rgba.reshape(-1, 4)[:, :3].mean(axis=1)
    if attr.domain == "POINT":
        return value
    corner_vert = np.empty(len(mesh.loops), np.int32)  # CORNER: each vertex's corners' mean
    mesh.loops.foreach_get("vertex_index", corner_vert)
    n = len(mesh.vertices)
    count = np.bincount(corner_vert, minlength=n)
    return (np.bincount(corner_vert, value, minlength=n) / np.maximum(count, 1)).astype(
        np.float32)


class HYDROBAKE_OT_fluid_capture_paint(bpy.types.Operator):
    """Local paint from the baked surface at this frame: its selected vertices, the active
    vertex group's weights or the active colour's brightness become a stroke of the texture
    (a point mesh in the domain's paint collection; re-bake to apply it)"""
    bl_idname = "hydrobake.fluid_capture_paint"
    bl_label = "Capture Paint"
    bl_options = {"REGISTER", "UNDO"}

    texture: bpy.props.IntProperty(name="Texture", default=1, min=0, max=7)
    source: bpy.props.EnumProperty(
        name="From", default="SELECTION",
        items=[("SELECTION", "Selection", "The selected vertices (Edit Mode)"),
               ("WEIGHTS", "Weights", "The active vertex group's weights (Weight Paint)"),
               ("COLOR", "Colour", "The active colour attribute's brightness (Vertex Paint; "
                                   "paint white over black, or tick Invert)")])
    invert: bpy.props.BoolProperty(
        name="Invert", default=False,
        description="One minus the value: paint black over a white colour attribute (Vertex "
                    "Paint starts one white), or capture what is not selected or weighted")

    invoke = _dialog
    poll = classmethod(_on_surface)

    def execute(self, context):
        surf, domain = _surface_and_domain(self, context)
        if surf is None:
            return {"CANCELLED"}
        mesh = surf.data
        cov = {"SELECTION": lambda: _selection(mesh).astype(np.float32),
               "WEIGHTS": lambda: _weights(surf), "COLOR": lambda: _colours(mesh)}[self.source]()
        if cov is None:
            what = "vertex group" if self.source == "WEIGHTS" else "colour attribute"
            self.report({"ERROR"}, f"From = {self.source}: the surface has no active {what}")
            return {"CANCELLED"}
        cov = np.clip(cov, 0.0, 1.0)
        if self.invert:
            cov = 1.0 - cov
        keep = cov > 0.0
        if not keep.any():
            self.report({"ERROR"}, f"From = {self.source}: nothing painted or selected on the "
                                   "surface at this frame")
            return {"CANCELLED"}
        pts = meshes.world_vertices(surf)[keep].astype(np.float32)
        # The frame the mesh holds: the scene may have moved on while it was in Edit Mode.
        frame = int(surf.get(frame_meshes.FRAME, context.scene.frame_current))
        name = f"HBK_{domain.name}_paint_{frame}"
        stroke_mesh = bpy.data.meshes.new(name)
        stroke_mesh.vertices.add(len(pts))
        stroke_mesh.vertices.foreach_set("co", pts.ravel())
        stroke_mesh.attributes.new("coverage", "FLOAT", "POINT").data.foreach_set(
            "value", cov[keep])
        stroke = bpy.data.objects.new(name, stroke_mesh)
        stroke.hide_render = True
        s = domain.hydrobake_fluid
        if s.paint_collection is None:
            s.paint_collection = bpy.data.collections.new(f"HBK_{domain.name}_paint")
            context.scene.collection.children.link(s.paint_collection)
        s.paint_collection.objects.link(stroke)
        p = stroke.hydrobake_fluid_paint
        p.enabled, p.texture, p.frame = True, self.texture, frame
        p.reach = min(p.reach, 8.0 * smallest_cell(domain))  # within a small domain's limit
        if frame != context.scene.frame_current:  # show the scene's frame again
            frame_meshes.load(surf, context.scene.frame_current)
        self.report({"INFO"}, f"Texture {self.texture} painted at {int(keep.sum())} vertices "
                              f"at frame {frame} ({stroke.name}); re-bake to apply")
        return {"FINISHED"}


class HYDROBAKE_OT_fluid_capture_rule(bpy.types.Operator):
    """Feature paint from a selection: the chosen feature's range over the selected vertices of
    the baked fluid surface becomes a rule giving the texture (re-bake to apply it)"""
    bl_idname = "hydrobake.fluid_capture_rule"
    bl_label = "Capture Feature Rule"
    bl_options = {"REGISTER", "UNDO"}

    texture: bpy.props.IntProperty(name="Texture", default=1, min=0, max=7)
    feature: bpy.props.EnumProperty(name="Feature", default="DENSITY_RATE",
                                    items=[(f, f.replace("_", " ").title(), "")
                                           for f in FEATURES])

    invoke = _dialog
    poll = classmethod(_on_surface)

    def execute(self, context):
        surf, domain = _surface_and_domain(self, context)
        if surf is None:
            return {"CANCELLED"}
        k = FEATURES.index(self.feature)
        attr = surf.data.attributes.get(f"features_{k}")
        sel = _selection(surf.data)
        if attr is None or not sel.any():
            self.report({"ERROR"}, "Select some vertices of the surface first (Edit Mode)")
            return {"CANCELLED"}
        vals = np.empty(len(surf.data.vertices), np.float32)
        attr.data.foreach_get("value", vals)
        rule = domain.hydrobake_fluid.rules.add()
        rule.texture, rule.feature = self.texture, self.feature
        rule.low, rule.high = float(vals[sel].min()), float(vals[sel].max())
        self.report({"INFO"}, f"Texture {self.texture} where {self.feature.lower()} is in "
                              f"[{rule.low:.4g}, {rule.high:.4g}]; re-bake to apply")
        return {"FINISHED"}


def smallest_cell(domain):
    """The domain's smallest grid cell (m): its own mesh's box (a liquid domain's bounds would
    be its liquid's) over its resolution."""
    lo, hi = (meshes.data_world_bounds(domain) if domain.type == "MESH"
              else meshes.world_bounds(domain))
    return float(np.min((hi - lo) / np.array(domain.hydrobake_fluid.fluid.resolution[:])))


def strokes(collection, ntex, cell, scene=None, frames=None, life=None):
    """The enabled strokes of a paint collection as the core's inputs: ({frame: [(texture,
    centre, radius, falloff)]} from Empties, {frame: [(texture, positions, coverage, radius,
    falloff)]} from meshes). cell: the grid's smallest cell size (m).

    Each stroke is taken where it is at its own frame (``scene`` is set to it, and back), as
    it paints then: an animated Empty paints where it is at that frame, not where it is when
    the bake starts. ``frames`` (first, last) and ``life`` ((paint_duration + paint_fade) in
    frames): a stroke before the first frame whose paint would still show then is refused
    (the bake starts after it, so it would never be laid)."""
    balls, points = {}, {}
    todo = []
    for e in collection.all_objects:
        p = getattr(e, "hydrobake_fluid_paint", None)
        if p is None or not p.enabled or e.type not in ("EMPTY", "MESH"):
            continue
        if p.texture >= ntex:
            raise ValueError(f"{e.name}: texture = {p.texture}: must be < textures = {ntex}")
        if frames is not None and p.frame < frames[0] and (
                life is None or frames[0] - p.frame < life):
            raise ValueError(
                f"{e.name}: Frame = {p.frame}: must be in [{frames[0]}, {frames[1]}], the "
                "bake's frame range: the bake starts after the stroke, which would never be "
                "painted, though its paint would still show (Paint Duration + Paint Fade)")
        if e.type == "MESH":
            most = float(f"{16.0 * cell / 1.5 * 0.9999:.4g}")  # quoted so that it can be typed
            if p.reach > most * (1.0 + 1e-6):  # the core's bound on a ball and fade (float32)
                raise ValueError(f"{e.name}: Reach = {p.reach:g} m: must be at most {most:g} m "
                                 "(with its fade, 16 voxels)")
        todo.append((p.frame, e))
    keep = scene.frame_current if scene is not None else None
    try:
        # By frame, in the collection's order within one (a later stroke wins where it
        # covers an earlier one).
        for frame, e in sorted(todo, key=lambda t: t[0]):
            if scene is not None and scene.frame_current != frame:
                scene.frame_set(frame)
            p = e.hydrobake_fluid_paint
            if e.type == "EMPTY":
                r = e.empty_display_size * max(e.matrix_world.to_scale())
                balls.setdefault(p.frame, []).append(
                    (p.texture, tuple(e.matrix_world.translation), r, 0.2 * r))
                continue
            cov = None
            attr = e.data.attributes.get("coverage")
            if attr is not None and attr.domain == "POINT" and attr.data_type == "FLOAT":
                cov = np.empty(len(e.data.vertices), np.float32)
                attr.data.foreach_get("value", cov)
                cov = np.clip(cov, 0.0, 1.0)
            points.setdefault(p.frame, []).append(
                (p.texture, meshes.world_vertices(e).astype(np.float32), cov, p.reach,
                 0.5 * p.reach))
    finally:
        if scene is not None and scene.frame_current != keep:
            scene.frame_set(keep)
    return balls, points


CLASSES = (HYDROBAKE_PG_fluid_paint, HYDROBAKE_PT_fluid_paint, HYDROBAKE_PT_fluid_surface,
           HYDROBAKE_OT_fluid_capture_paint, HYDROBAKE_OT_fluid_capture_rule)
