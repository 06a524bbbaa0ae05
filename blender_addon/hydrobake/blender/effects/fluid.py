"""Fluid texturing in Blender: the domain object's bounding box is the simulation box; the
fluid is the built-in SPH (filling a Fill object's box) or a particle system's particles; the
bake becomes a Volume object reading the VDB sequence and a surface mesh that follows the frame,
with a material that blends two solid textures at the advected uvw, cross-fading fields A and B."""
import bpy
import numpy as np

from ..bridge import frame_meshes, materials, meshes, volumes
from . import register_effect
from .base import BlenderEffect


FEATURES = ("DENSITY", "DENSITY_RATE", "FLOW_ANGLE", "ACCELERATION", "DIVERGENCE")
OPEN = 3.0e38  # a feature bound that does not matter


class HYDROBAKE_PG_fluid_paint(bpy.types.PropertyGroup):
    """An Empty that paints a sample texture into the fluid (paper §3.1, local paint)."""
    enabled: bpy.props.BoolProperty(
        name="Paint Fluid", default=False,
        description="Paint a texture into the fluid where this empty is, at its frame; the "
                    "paint flows with the fluid and fades (Paint Duration, Paint Fade)")
    texture: bpy.props.IntProperty(name="Texture", default=1, min=0, max=7,
                                   description="Sample texture painted (0-based)")
    frame: bpy.props.IntProperty(name="Frame", default=1, min=0, max=1048574,
                                 description="Frame at which the stroke is applied")


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


class HYDROBAKE_PT_fluid_paint(bpy.types.Panel):
    bl_label = "Hydrobake Fluid Paint"
    bl_space_type, bl_region_type, bl_context = "PROPERTIES", "WINDOW", "object"
    bl_options = {"DEFAULT_CLOSED"}

    @classmethod
    def poll(cls, context):
        return context.object is not None and context.object.type == "EMPTY"

    def draw(self, context):
        p = context.object.hydrobake_fluid_paint
        col = self.layout.column()
        col.use_property_split = True
        col.prop(p, "enabled")
        sub = col.column()
        sub.active = p.enabled
        sub.prop(p, "texture")
        sub.prop(p, "frame")
        col.label(text="Radius: the empty's display size x scale")


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

    def execute(self, context):
        surf = context.object
        domain = bpy.data.objects.get(surf.get("hydrobake_domain", "")) if surf else None
        if domain is None:
            self.report({"ERROR"}, "Select the baked fluid surface (HBK_<domain>_surface)")
            return {"CANCELLED"}
        if surf.mode == "EDIT":
            bpy.ops.object.mode_set(mode="OBJECT")  # writes the edit-mode selection back
        k = FEATURES.index(self.feature)
        attr = surf.data.attributes.get(f"features_{k}")
        sel = np.zeros(len(surf.data.vertices), bool)
        surf.data.vertices.foreach_get("select", sel)
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
                description="SIMULATE: particles fill this object's bounding box at frame one"),
            particle_object=bpy.props.PointerProperty(
                name="Particles", type=bpy.types.Object,
                description="PARTICLES: the object whose first particle system is the fluid "
                            "(positions and velocities read every frame)"),
            obstacles=bpy.props.PointerProperty(
                name="Obstacles", type=bpy.types.Collection,
                description="SIMULATE: objects the fluid flows around (their bounding boxes)"),
            paint_collection=bpy.props.PointerProperty(
                name="Paint", type=bpy.types.Collection,
                description="Empties with Paint Fluid on: local paint strokes (Object tab)"),
            rules=bpy.props.CollectionProperty(
                type=HYDROBAKE_PG_fluid_rule, name="Feature Rules",
                description="Feature paint: a texture wherever a feature lies in a range"),
        )

    @classmethod
    def prepare(cls, context, obj, settings, params, frames):
        lo, hi = meshes.world_bounds(obj)
        fp = params["fluid"]
        fp["box_min"], fp["box_max"] = tuple(map(float, lo)), tuple(map(float, hi))
        fps = context.scene.render.fps / context.scene.render.fps_base
        fp["dt"] = 1.0 / fps
        inputs = {}
        if fp["source"] == 0:
            if settings.fill_object is None:
                raise ValueError("Fill: SIMULATE needs an object whose box the fluid fills")
            flo, fhi = meshes.world_bounds(settings.fill_object)
            inputs["fill"] = (tuple(map(float, np.maximum(flo, lo))),
                              tuple(map(float, np.minimum(fhi, hi))))
            if settings.obstacles:
                obs = []
                for o in settings.obstacles.all_objects:
                    olo, ohi = meshes.world_bounds(o)
                    obs.append(("box", tuple((olo + ohi) / 2), tuple((ohi - olo) / 2)))
                inputs["obstacles"] = obs[:64]
        elif fp["source"] == 1:
            if settings.particle_object is None:
                raise ValueError("Particles: PARTICLES needs an object with a particle system")
            inputs["particles"] = cls._particles(context, settings.particle_object, frames,
                                                 lo, hi)
        else:
            raise ValueError("source: VELOCITY_GRID (Mantaflow caches) is not wired into "
                             "Blender yet; use SIMULATE or PARTICLES")
        ntex = fp["textures"]
        if settings.paint_collection:
            strokes = {}
            for e in settings.paint_collection.all_objects:
                p = getattr(e, "hydrobake_fluid_paint", None)
                if p is None or not p.enabled or e.type != "EMPTY":
                    continue
                if p.texture >= ntex:
                    raise ValueError(f"{e.name}: texture = {p.texture}: must be < textures "
                                     f"= {ntex}")
                r = e.empty_display_size * max(e.matrix_world.to_scale())
                strokes.setdefault(p.frame, []).append(
                    (p.texture, tuple(e.matrix_world.translation), r, 0.2 * r))
            inputs["paint"] = strokes
        rules = []
        for rule in settings.rules:
            if rule.texture >= ntex:
                raise ValueError(f"Feature rule: texture = {rule.texture}: must be < textures "
                                 f"= {ntex}")
            lo, hi = [-OPEN] * len(FEATURES), [OPEN] * len(FEATURES)
            k = FEATURES.index(rule.feature)
            lo[k], hi[k] = rule.low, rule.high
            rules.append((rule.texture, lo, hi))
        inputs["rules"] = rules
        return params, inputs

    @staticmethod
    def _particles(context, pobj, frames, lo, hi):
        scene = context.scene
        keep = scene.frame_current
        out = {}
        try:
            for f in range(frames[0], frames[1] + 1):
                scene.frame_set(f)
                ev = pobj.evaluated_get(context.evaluated_depsgraph_get())
                if not ev.particle_systems:
                    raise ValueError(f"{pobj.name}: has no particle system")
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
                out[f] = (pos[inside], vel[inside])
        finally:
            scene.frame_set(keep)
        return out

    @classmethod
    def apply(cls, context, obj, settings, folder, manifest):
        frames = sorted(int(f) for f in manifest["frames"])
        coll = obj.users_collection[0] if obj.users_collection else None
        vol = volumes.load_volume_sequence(folder, "fluid", frames[0], len(frames),
                                           f"HBK_{obj.name}_volume", collection=coll)
        # The grids are for shading and for other tools; the render shows the textured
        # surface (enable the volume in renders to see the density as fog).
        vol.hide_render = True
        vol.display_type = "BOUNDS"
        mat = bpy.data.materials.get(f"HBK_{obj.name}_textured") or cls._material(
            f"HBK_{obj.name}_textured")
        surf = frame_meshes.attach(f"HBK_{obj.name}_surface", "surface", folder, "surface",
                                   collection=coll, material=mat)
        surf["hydrobake_domain"] = obj.name  # for Capture Feature Rule
        # The domain is only a box: show the fluid, not the box (Free Bake shows it again).
        obj.display_type = "BOUNDS"
        obj.hide_render = True

    @staticmethod
    def _material(name):
        """Three solid sample textures (noise, waves, cells) at the advected uvw, each
        cross-faded between fields A and B by uvw_weight, blended by the baked weights."""
        mat = bpy.data.materials.new(name)
        mat.use_nodes = True
        tree = mat.node_tree
        bsdf = materials.principled(tree)
        bsdf.inputs["Roughness"].default_value = 0.25

        def attr(name, x, y, kind="Vector"):
            n = tree.nodes.new("ShaderNodeAttribute")
            n.attribute_name, n.location = name, (x, y)
            return n.outputs[kind]

        def sample(kind, uvw, x, y):
            if kind == "noise":
                t = tree.nodes.new("ShaderNodeTexNoise")
                t.inputs["Scale"].default_value = 3.0
                t.inputs["Detail"].default_value = 6.0
            elif kind == "voronoi":
                t = tree.nodes.new("ShaderNodeTexVoronoi")
                t.inputs["Scale"].default_value = 6.0
            else:
                t = tree.nodes.new("ShaderNodeTexWave")
                t.inputs["Scale"].default_value = 2.0
                t.inputs["Distortion"].default_value = 4.0
            t.location = (x, y)
            tree.links.new(uvw, t.inputs["Vector"])
            return t.outputs["Color"]

        def mix(fac, a, b, x, y):
            m = tree.nodes.new("ShaderNodeMixRGB")
            m.location = (x, y)
            tree.links.new(fac, m.inputs["Fac"])
            tree.links.new(a, m.inputs["Color1"])
            tree.links.new(b, m.inputs["Color2"])
            return m.outputs["Color"]

        ua, ub = attr("uvw_a", -1200, 200), attr("uvw_b", -1200, -100)
        w = attr("uvw_weight", -1200, 400, "Fac")
        tex = []
        tints = ((0.15, 0.45, 0.9, 1), (0.95, 0.97, 1.0, 1), (1.0, 0.45, 0.1, 1))
        for k, kind in enumerate(("noise", "wave", "voronoi")):
            a = sample(kind, ua, -900, 300 - 300 * k)
            b = sample(kind, ub, -900, 150 - 300 * k)
            faded = mix(w, b, a, -700, 250 - 300 * k)  # fac = weight of A
            tint = tree.nodes.new("ShaderNodeMixRGB")  # each sample its own colour
            tint.blend_type, tint.location = "MULTIPLY", (-550, 250 - 300 * k)
            tint.inputs["Fac"].default_value = 1.0
            tint.inputs["Color2"].default_value = tints[k]
            tree.links.new(faded, tint.inputs["Color1"])
            tex.append(tint.outputs["Color"])
        # Blend weights sum to one: texture 1 over 0 by blend_1, then texture 2 by blend_2.
        out = mix(attr("blend_1", -600, 500, "Fac"), tex[0], tex[1], -300, 200)
        out = mix(attr("blend_2", -300, 500, "Fac"), out, tex[2], -100, 200)
        tree.links.new(out, bsdf.inputs["Base Color"])
        return mat

    @classmethod
    def remove(cls, context, obj, settings):
        frame_meshes.detach(f"HBK_{obj.name}_surface")
        vol = bpy.data.objects.get(f"HBK_{obj.name}_volume")
        if vol is not None:
            data = vol.data
            bpy.data.objects.remove(vol)
            if data.users == 0:
                bpy.data.volumes.remove(data)
        obj.display_type = "TEXTURED"
        obj.hide_render = False

    @classmethod
    def register_extra(cls):
        frame_meshes.ensure_handler()
        for c in (HYDROBAKE_PG_fluid_paint, HYDROBAKE_PT_fluid_paint,
                  HYDROBAKE_OT_fluid_capture_rule):
            bpy.utils.register_class(c)
        bpy.types.Object.hydrobake_fluid_paint = bpy.props.PointerProperty(
            type=HYDROBAKE_PG_fluid_paint)

    @classmethod
    def unregister_extra(cls):
        frame_meshes.unregister()
        del bpy.types.Object.hydrobake_fluid_paint
        for c in (HYDROBAKE_OT_fluid_capture_rule, HYDROBAKE_PT_fluid_paint,
                  HYDROBAKE_PG_fluid_paint):
            bpy.utils.unregister_class(c)

    @staticmethod
    def extra_classes():
        """Registered before the settings, which hold rules of this type."""
        return (HYDROBAKE_PG_fluid_rule,)

    @classmethod
    def draw_settings(cls, layout, settings):
        col = layout.column()
        for name in ("fill_object", "particle_object", "obstacles", "paint_collection"):
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
        super().draw_settings(layout, settings)
