"""Fluid texturing in Blender: the domain object's bounding box is the simulation box; the
fluid is the built-in SPH (filling a Fill object's box) or a particle system's particles; the
bake becomes a Volume object reading the VDB sequence and a surface mesh that follows the frame,
with a material that blends two solid textures at the advected uvw, cross-fading fields A and B."""
import bpy
import numpy as np

from ..bridge import frame_meshes, materials, meshes, volumes
from . import register_effect
from .base import BlenderEffect


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
        frame = obj.users_scene[0].frame_current if obj.users_scene else \
            context.scene.frame_current
        frame_meshes.attach(f"HBK_{obj.name}_surface", "surface", folder, "surface", frame,
                            collection=coll, material=mat)
        # The domain is only a box: show the fluid, not the box (Free Bake shows it again).
        obj.display_type = "BOUNDS"
        obj.hide_render = True

    @staticmethod
    def _material(name):
        """Two solid sample textures at the advected uvw, each cross-faded between fields A and
        B by uvw_weight, blended by the baked blend_1 weight."""
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
        for k, kind in enumerate(("noise", "wave")):
            a = sample(kind, ua, -900, 300 - 300 * k)
            b = sample(kind, ub, -900, 150 - 300 * k)
            tex.append(mix(w, b, a, -600, 250 - 300 * k))  # fac = weight of A
        out = mix(attr("blend_1", -600, 500, "Fac"), tex[0], tex[1], -300, 200)
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

    @classmethod
    def unregister_extra(cls):
        frame_meshes.unregister()

    @classmethod
    def draw_settings(cls, layout, settings):
        col = layout.column()
        for name in ("fill_object", "particle_object", "obstacles"):
            col.prop(settings, name)
        super().draw_settings(layout, settings)
