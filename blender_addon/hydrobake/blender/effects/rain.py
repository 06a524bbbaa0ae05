"""Windshield rain in Blender: the glass object's UV layout is the simulation grid (curved
glass: gravity and airflow act along each cell's own tangents, taken from the mesh), the
glass's physical size sets the grid, a car object's animation gives speed and acceleration.
The normal-map sequence is wired into the glass material (tangent space, its UV map) on the
glass's outer face, the glass given a thickness so drops refract as lenses."""
import bpy
import numpy as np
from mathutils import Vector

from ...core.rain import MAX_CELLS
from ..bridge import animation, images, materials, mesh_data, uv_grid
from ..bridge.depsgraph import evaluated as evaluated_depsgraph
from . import register_effect
from .base import BlenderEffect, warn_uv_overlap

THICKNESS = "HBK Glass Thickness"  # the Solidify modifier apply adds to a one-face glass
AXES = {"-Y": (0, -1, 0), "+Y": (0, 1, 0), "-X": (-1, 0, 0), "+X": (1, 0, 0)}


@register_effect
class RainBlender(BlenderEffect):
    name = "rain"
    label = "Windshield Rain"
    wired_prefix, wired_streams = "rain.", ("rain_normal",)
    made_material = "glass"
    icon = "MOD_FLUIDSIM"
    refracts = True
    presets = {
        "Drizzle": {"rain": {"rain_rate": 80.0, "drop_mass": 1.5}},
        "Downpour": {"rain": {"rain_rate": 1500.0, "drop_mass": 5.0}},
        "Highway": {"rain": {"rain_rate": 400.0, "car_speed": 25.0}},
    }

    @classmethod
    def extra_properties(cls):
        return dict(
            car_object=bpy.props.PointerProperty(
                name="Car", type=bpy.types.Object,
                description="Object whose animation is the car's motion: its speed pushes "
                            "drops up the glass, its acceleration adds an inertial force. "
                            "Empty: the Car Speed / Car Accel parameters"),
            forward_axis=bpy.props.EnumProperty(
                name="Car Forward", default="+Y", items=[(k, k, "") for k in AXES],
                description="The car's (or glass's) local axis that points forward"),
            background_image=bpy.props.PointerProperty(
                name="Preview Background", type=bpy.types.Image,
                description="Image seen through the glass for the cheap refraction preview "
                            "sequence (the paper's method); empty: no preview"),
            wiper_0=bpy.props.PointerProperty(
                name="Wiper 1", type=bpy.types.Object,
                description="Animated wiper: its local Z rotation (degrees, PIVOT) or local X "
                            "location (metres, TRANSLATE) drives blade 1 every frame, instead of "
                            "the period"),
            wiper_1=bpy.props.PointerProperty(
                name="Wiper 2", type=bpy.types.Object,
                description="Animated wiper driving blade 2 (as Wiper 1)"),
            substeps=bpy.props.IntProperty(
                name="Substeps", default=2, min=1, max=100,
                description="Simulation steps per frame"),
            use_mesh_size=bpy.props.BoolProperty(
                name="Grid From Mesh", default=True,
                description="Set the grid's cell counts from the glass's physical size and "
                            "the cell size; map resolution twice the cells"),
        )

    @classmethod
    def evaluated_inputs(cls, obj, settings):
        return [(None, obj)]

    @classmethod
    def prepare(cls, context, obj, settings, params, frames):
        scene = context.scene
        # The glass's own surface: without the thickness the bake adds (two faces per UV).
        thick = [m for m in obj.modifiers if m.type == "SOLIDIFY" and m.show_viewport]
        for m in thick:
            m.show_viewport = False
        try:
            pos, tris, uvs, _ = mesh_data.triangles(obj, evaluated_depsgraph(context))
        finally:
            for m in thick:
                m.show_viewport = True
        if uvs is None:
            raise ValueError(f"{obj.name}: needs a UV map (the glass is simulated in UV space)")
        warn_uv_overlap(obj, uvs, "the drops of one run on all of them (the glass is simulated "
                        "in UV space: unwrap it without overlaps)")
        rp = params["rain"]
        cls._check_materials(obj)
        if settings.use_mesh_size:
            mu, mv = uv_grid.physical_size(pos, tris, uvs)
            cells = (round(mu / rp["cell_size"]), round(mv / rp["cell_size"]))
            if min(cells) < 8:  # the grid's least; a bigger grid would be a bigger glass
                largest = min(mu, mv) / 8.0
                raise ValueError(
                    f"Cell Size = {rp['cell_size']:g} m: gives {cells[0]} x {cells[1]} cells on "
                    f"this {mu:.3g} x {mv:.3g} m glass, fewer than 8 each way; use at most "
                    f"{largest:.3g} m")
            rp["width"] = int(np.clip(cells[0], 8, 16384))
            rp["height"] = int(np.clip(cells[1], 8, 16384))
            if rp["width"] * rp["height"] > MAX_CELLS:
                # The kernel's limit, said in the setting the user chose (not width x height).
                smallest = float(np.sqrt(mu * mv / MAX_CELLS)) * 1.001
                raise ValueError(
                    f"Cell Size = {rp['cell_size']:g} m: gives {rp['width']} x "
                    f"{rp['height']} cells on this {mu:.3g} x {mv:.3g} m glass, past the "
                    f"{MAX_CELLS} allowed; use at least {smallest:.3g} m")
            rp["map_width"] = int(min(2 * rp["width"], 16384))
            rp["map_height"] = int(min(2 * rp["height"], 16384))
        carrier = settings.car_object or obj
        fwd = carrier.matrix_world.to_3x3() @ Vector(AXES[settings.forward_axis])
        back = -np.array(fwd.normalized(), np.float64)
        field, mask = uv_grid.rasterize(pos, tris, uvs, rp["width"], rp["height"],
                                        back=back)
        if mask.mean() < 0.01:  # the grid is UV 0..1: a layout elsewhere simulates no glass
            uv = obj.data.uv_layers.active.name
            raise ValueError(f"{obj.name}: its UV map '{uv}' covers {100 * mask.mean():.2g}% "
                             "of the 0..1 square (the glass is simulated there); unwrap the "
                             "glass into it")
        inputs = dict(gravity_dir=field, mask=mask, substeps=settings.substeps,
                      fps=scene.render.fps / scene.render.fps_base)
        if settings.car_object:
            inputs["car"] = yield from cls._car_motion(scene, settings.car_object,
                                                       AXES[settings.forward_axis], frames)
        blades = [o for o in (settings.wiper_0, settings.wiper_1) if o is not None]
        if blades:
            if len(blades) != rp["wiper_count"]:
                raise ValueError(f"Wipers: {len(blades)} animated wiper object(s) for "
                                 f"wiper_count = {rp['wiper_count']}; set one per blade")
            inputs["wipers"] = yield from cls._wiper_motion(scene, blades, rp["wiper_mode"],
                                                            frames)
        if settings.background_image is not None:
            inputs["background"] = images.pixels(settings.background_image, colour=True,
                                                 role="Preview Background")
        return params, inputs

    @staticmethod
    def _car_motion(scene, car, axis, frames):
        """{frame: (speed, acceleration)} along the car's forward axis as it points at each
        frame (a car that turns keeps its speed), from its animation. Keys that start or stop
        the car make an instant change (hundreds of m/s^2 between two frames): the
        acceleration is clamped to the kernel's +-50 m/s^2 (5 g)."""
        fps = scene.render.fps / scene.render.fps_base

        def sample(_f):
            m = car.matrix_world
            return (np.array(m.translation),
                    np.array((m.to_3x3() @ Vector(axis)).normalized()))
        at = yield from animation.per_frame(scene, frames[0] - 2, frames[1], sample)
        speed = {f: max(0.0, float((at[f][0] - at[f - 1][0]) @ at[f][1]) * fps)
                 for f in range(frames[0] - 1, frames[1] + 1)}
        fast = max(speed, key=speed.get)
        if speed[fast] > 100.0:
            raise ValueError(f"Car: {car.name} moves at {speed[fast]:.4g} m/s at frame {fast}; "
                             "at most 100 m/s")
        return {f: (speed[f], float(np.clip((speed[f] - speed[f - 1]) * fps, -50.0, 50.0)))
                for f in range(frames[0], frames[1] + 1)}

    @staticmethod
    def _wiper_motion(scene, blades, mode, frames):
        """{frame: [value per blade]}: the local rotation about Z in degrees (PIVOT, mode 1:
        the Euler Z of its rotation mode, or from a quaternion or axis-angle, kept continuous
        from frame to frame) or local X location in metres (TRANSLATE), from the animation."""
        last = {}

        def turn(b):
            if b.rotation_mode not in ("QUATERNION", "AXIS_ANGLE"):
                return float(np.degrees(b.rotation_euler.z))  # its own Euler order's Z
            q = b.matrix_basis.to_quaternion()
            e = q.to_euler("XYZ", last[b.name]) if b.name in last else q.to_euler("XYZ")
            last[b.name] = e
            return float(np.degrees(e.z))
        return (yield from animation.per_frame(scene, frames[0], frames[1], lambda f: [
            turn(b) if mode == 1 else float(b.location.x) for b in blades]))

    @staticmethod
    def _shader(tree):
        """The material's surface shader the drops' normals go into: Principled or Glass."""
        return materials.principled(tree) or next(
            (n for n in tree.nodes if n.type == "BSDF_GLASS"), None)

    @classmethod
    def _check_materials(cls, obj):
        """Refused before the bake: materials none of which can take the drops' normals."""
        mats = [s.material for s in obj.material_slots if s.material]
        if not mats:
            return  # one is made
        def takes(m):  # a material without a node tree gets the default one (Principled)
            return m.node_tree is None or cls._shader(m.node_tree) is not None
        if not any(takes(m) for m in mats):
            raise ValueError(f"{obj.name}: its materials ({', '.join(m.name for m in mats)}) "
                             "have no Principled or Glass BSDF for the drops' normals")

    @classmethod
    def apply(cls, context, obj, settings, folder, manifest):
        """A drop is a thin water lens on the glass's outer face. Light enters the glass
        through its flat inner face and leaves through the drop's surface: only the two faces
        together bend it by the drop's slope alone (a single face would bend every ray towards
        its normal, and the glass would show the sky). So the glass gets a thickness (a
        Solidify modifier when it has none) and one refracting material with the water's index;
        its normal is the drop normal map on the faces rays leave by (back-facing), the flat
        normal on those they enter by. Dry glass is then an exact parallel plate."""
        frames = sorted(int(f) for f in manifest["frames"])
        if not any(m.type == "SOLIDIFY" and m.show_render for m in obj.modifiers):
            mod = obj.modifiers.get(THICKNESS) or obj.modifiers.new(THICKNESS, "SOLIDIFY")
            mod.thickness = 0.004
            mod.offset = 0.0
            mod.use_even_offset = True
        # Every material of the glass gets the drops (a frit band is wet too); the glass
        # values go to the glass-like ones (Glass BSDF, or transmission), else to the first.
        if not any(s.material for s in obj.material_slots):
            # A new material (Free Bake takes it away), or the mesh's where the object's slots
            # lag its list: that one may be another object's too, so it goes through own().
            materials.ensure_material(obj, cls.made_material_name(obj.name), nodes=False)
        mats = [materials.own(obj, i, cls._unwire) for i in range(len(obj.material_slots))]
        mats = list(dict.fromkeys(m for m in mats if m is not None))
        for mat in mats:
            materials.use_nodes(mat)
        wired = [m for m in mats if cls._shader(m.node_tree) is not None]
        glassy = [m for m in wired if cls._glassy(cls._shader(m.node_tree))] or wired[:1]
        for mat in wired:
            cls._wire(obj, mat, folder, frames, values=mat in glassy)
        if "preview" in manifest.get("streams", []) and settings.background_image is not None:
            images.load_unused_sequence(folder, "preview", frames[0], len(frames),
                                        f"HBK_{obj.name}_rain_preview")

    @classmethod
    def _unwire(cls, tree):
        """Takes the drops out of a material: its own normal (a bump, say, that fed the
        inner face) back into the shader."""
        side = materials.tagged(tree, "rain.side")
        shader = cls._shader(tree)
        c1 = side.inputs["Color1"] if side is not None else None
        if c1 is not None and c1.is_linked and shader is not None and \
                not c1.links[0].from_node.get(materials.TAG):
            tree.links.new(c1.links[0].from_socket, shader.inputs["Normal"])
        materials.remove_tagged(tree, "rain.")

    @staticmethod
    def _glassy(shader):
        return shader.type == "BSDF_GLASS" or \
            shader.inputs["Transmission"].default_value >= 0.5

    @classmethod
    def _wire(cls, obj, mat, folder, frames, values):
        tree = mat.node_tree
        bsdf = cls._shader(tree)
        if values:  # glass and drops as one water plate (Free Bake gives the values back)
            want = {"Roughness": 0.0, "IOR": 1.33}
            if "Transmission" in bsdf.inputs:
                want["Transmission"] = 1.0
            materials.set_inputs(mat, bsdf, want, "rain.")
            materials.see_through(mat, blend=True)
        uv = obj.data.uv_layers.active.name if obj.data.uv_layers.active else ""
        x, y = bsdf.location
        uvn = materials.add_node(tree, "ShaderNodeUVMap", "rain.uv", (x - 1100, y - 300))
        uvn.uv_map = uv
        tex = materials.add_node(tree, "ShaderNodeTexImage", "rain.normal", (x - 850, y - 300))
        tex.image = images.load_sequence(folder, "normal", frames[0], len(frames),
                                         name=f"HBK_{obj.name}_rain_normal")
        tex.extension = "EXTEND"
        images.configure_user(tex.image_user, frames[0], len(frames))
        tree.links.new(uvn.outputs["UV"], tex.inputs["Vector"])
        nm = materials.add_node(tree, "ShaderNodeNormalMap", "rain.normalmap", (x - 550, y - 300))
        nm.space = "TANGENT"
        nm.uv_map = uv
        tree.links.new(tex.outputs["Color"], nm.inputs["Color"])
        geo = materials.add_node(tree, "ShaderNodeNewGeometry", "rain.geometry", (x - 550, y - 50))
        side = materials.add_node(tree, "ShaderNodeMixRGB", "rain.side", (x - 250, y - 200))
        side.use_clamp = False
        normal = bsdf.inputs["Normal"]
        # The faces rays enter by keep the material's own normal (a Bump of its own, say), or
        # the flat one; Free Bake links the material's own back.
        theirs = normal.links[0].from_socket if normal.is_linked and \
            normal.links[0].from_node != side else None
        tree.links.new(geo.outputs["Backfacing"], side.inputs["Fac"])
        if theirs is not None:
            tree.links.new(theirs, side.inputs["Color1"])
        elif not side.inputs["Color1"].is_linked:
            tree.links.new(geo.outputs["Normal"], side.inputs["Color1"])
        tree.links.new(nm.outputs["Normal"], side.inputs["Color2"])
        tree.links.new(side.outputs["Color"], normal)

    @classmethod
    def let_go(cls, context, obj, settings, keep):
        mod = obj.modifiers.get(THICKNESS)
        if mod is not None:
            obj.modifiers.remove(mod)
        for mat in cls.slot_materials(obj, settings) - set(keep):
            if mat.node_tree:
                cls._unwire(mat.node_tree)
            materials.give_back(obj, mat, "rain.")
        materials.restore(obj, "rain.")

    @classmethod
    def remove(cls, context, obj, settings):
        mod = obj.modifiers.get(THICKNESS)
        if mod is not None:
            obj.modifiers.remove(mod)
        # The bake's wiring wherever it is: in the object's slots, and in materials taken
        # out of them since (or a shared one a re-bake made a copy of), known by its images.
        name = cls.baked_name(obj, settings)
        mats = cls.slot_materials(obj, settings)
        mats |= set(materials.holding("rain.", {f"HBK_{name}_rain_normal"}))
        for mat in mats:
            if mat.node_tree:
                cls._unwire(mat.node_tree)
            materials.give_back(obj, mat, "rain.")
        materials.restore(obj, "rain.", made=cls.made_material_name(name))
        cls._remove_images(name)

    @classmethod
    def forget(cls, name):
        materials.forget(name, "rain.", {f"HBK_{name}_rain_normal"}, cls._unwire)
        cls._remove_images(name)

    @staticmethod
    def _remove_images(name):
        for stream in ("preview", "normal"):
            images.remove(f"HBK_{name}_rain_{stream}")

    @classmethod
    def draw_settings(cls, layout, settings):
        col = layout.column()
        for name in ("car_object", "forward_axis", "wiper_0", "wiper_1", "background_image",
                     "substeps",
                     "use_mesh_size"):
            col.prop(settings, name)
        super().draw_settings(layout, settings)
