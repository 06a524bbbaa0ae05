"""Snow in Blender: the object's evaluated mesh (world space, its active UV map) is the target;
objects in a collider collection shelter it; each material says how well it catches snow and
whether it melts or sheds flakes. The coverage and depth sequences are mixed into every
material of the object non-destructively (Free Bake takes them out again)."""
import bpy
import numpy as np

from ..bridge import frame_meshes, images, materials, mesh_data, points
from . import register_effect
from .base import BlenderEffect

# The paper's figures for rough materials (catch chance): §4.1.6.
CATCH_PRESETS = {"SMOOTH": 0.0, "SHOES": 0.10, "TROUSERS": 0.25, "COAT": 0.40}


class HYDROBAKE_PG_snow_material(bpy.types.PropertyGroup):
    """How a material takes snow."""
    catch: bpy.props.EnumProperty(
        name="Catch", default="ROUGHNESS",
        items=[("ROUGHNESS", "From Roughness", "0.5 x roughness x (1 - metallic) of the "
                "material's Principled BSDF"),
               ("SMOOTH", "Smooth (0 %)", "Smooth metal, glass, car paint"),
               ("SHOES", "Shoes (10 %)", "The paper's shoes"),
               ("TROUSERS", "Trousers (25 %)", "The paper's trousers"),
               ("COAT", "Coat (40 %)", "The paper's coat: rough cloth"),
               ("CUSTOM", "Custom", "Use Catch Chance")],
        description="Chance that the surface's roughness catches a flake that would not "
                    "stick by temperature alone")
    catch_chance: bpy.props.FloatProperty(
        name="Catch Chance", default=0.0, min=0.0, max=0.5, subtype="FACTOR",
        description="Custom catch chance, 0 (smooth) to 0.5 (very rough)")
    melts: bpy.props.BoolProperty(
        name="Melts Snow", default=False,
        description="Warm surface (skin): flakes melt on contact and leave no snow")
    sheds: bpy.props.BoolProperty(
        name="Sheds Snow", default=False,
        description="Moving surface (spinning tyres): flakes are thrown off and leave no snow")


def catch_of(mat):
    if mat is None:
        return 0.0, False, False
    s = mat.hydrobake_snow
    if s.catch == "CUSTOM":
        c = s.catch_chance
    elif s.catch == "ROUGHNESS":
        bsdf = materials.principled(mat.node_tree) if mat.use_nodes and mat.node_tree else None
        rough = bsdf.inputs["Roughness"].default_value if bsdf else mat.roughness
        metal = bsdf.inputs["Metallic"].default_value if bsdf else mat.metallic
        c = 0.5 * rough * (1.0 - metal)
    else:
        c = CATCH_PRESETS[s.catch]
    return float(c), bool(s.melts), bool(s.sheds)


class HYDROBAKE_PT_snow_material(bpy.types.Panel):
    bl_label = "Hydrobake Snow"
    bl_space_type, bl_region_type, bl_context = "PROPERTIES", "WINDOW", "material"
    bl_options = {"DEFAULT_CLOSED"}

    @classmethod
    def poll(cls, context):
        return context.material is not None

    def draw(self, context):
        s = context.material.hydrobake_snow
        col = self.layout.column()
        col.use_property_split = True
        col.prop(s, "catch")
        sub = col.row()
        sub.active = s.catch == "CUSTOM"
        sub.prop(s, "catch_chance")
        col.prop(s, "melts")
        col.prop(s, "sheds")
        c, _, _ = catch_of(context.material)
        col.label(text=f"Catch chance used: {c:.0%}")


def _flake_material():
    mat = bpy.data.materials.new("HBK Snow Flake")
    mat.use_nodes = True
    bsdf = materials.principled(mat.node_tree)
    bsdf.inputs["Base Color"].default_value = (1.0, 1.0, 1.0, 1.0)
    bsdf.inputs["Roughness"].default_value = 0.9
    return mat


def _unwire(tree):
    """Takes the snow out of a material: its surface shader back where the mix was."""
    mix = materials.tagged(tree, "snow.mix")
    if mix is not None and mix.inputs[1].is_linked:
        src = mix.inputs[1].links[0].from_socket
        for link in list(mix.outputs["Shader"].links):
            tree.links.new(src, link.to_socket)
    materials.remove_tagged(tree, "snow.")


@register_effect
class SnowBlender(BlenderEffect):
    name = "snow"
    label = "Snow"
    icon = "FREEZE"
    presets = {
        "Wet Snow (+1 °C)": {"snow": {"temperature": 1.0, "fall_speed": 1.2}},
        "Powder (-8 °C)": {"snow": {"temperature": -8.0, "fall_speed": 0.7,
                                    "flutter_amplitude": 0.4}},
        "Blizzard": {"snow": {"temperature": -4.0, "wind": (6.0, 0.0, 0.0),
                              "flake_count": 1000000}},
    }

    @classmethod
    def register_extra(cls):
        bpy.utils.register_class(HYDROBAKE_PG_snow_material)
        bpy.utils.register_class(HYDROBAKE_PT_snow_material)
        bpy.types.Material.hydrobake_snow = bpy.props.PointerProperty(
            type=HYDROBAKE_PG_snow_material)
        frame_meshes.ensure_handler()  # flake objects saved in a .blend follow the frame

    @classmethod
    def unregister_extra(cls):
        frame_meshes.unregister()
        del bpy.types.Material.hydrobake_snow
        bpy.utils.unregister_class(HYDROBAKE_PT_snow_material)
        bpy.utils.unregister_class(HYDROBAKE_PG_snow_material)

    @classmethod
    def extra_properties(cls):
        return dict(
            colliders=bpy.props.PointerProperty(
                name="Colliders", type=bpy.types.Collection,
                description="Objects that shelter this one (a roof, a tree); flakes hitting "
                            "them are removed"),
            auto_volume=bpy.props.BoolProperty(
                name="Auto Volume", default=True,
                description="Fit the snow volume around the object and colliders, widened "
                            "upwind so wind-blown flakes reach it"),
            use_displacement=bpy.props.BoolProperty(
                name="Displacement", default=True,
                description="Displace the surface by the baked snow depth"),
            write_flakes=bpy.props.BoolProperty(
                name="Flakes as Points", default=False,
                description="Also bake the falling flakes' positions per frame"),
        )

    @classmethod
    def prepare(cls, context, obj, settings, params, frames):
        scene = context.scene
        dg = context.evaluated_depsgraph_get()
        pos, tris, uvs, mi = mesh_data.triangles(obj, dg)
        if uvs is None:
            raise ValueError(f"{obj.name}: needs a UV map (the snow textures live in UV space)")
        slots = [catch_of(s.material) for s in obj.material_slots] or [(0.0, False, False)]
        parts = [(pos, tris, uvs, mi)]
        n = len(pos)
        if settings.colliders:
            shelter = len(slots)
            slots.append((0.0, False, True))  # colliders take no snow: flakes end there
            for o in settings.colliders.all_objects:
                if o.type != "MESH" or o == obj:
                    continue
                p, t, _, _ = mesh_data.triangles(o, dg)
                parts.append((p, t + n, np.zeros((len(t), 3, 2), np.float32),
                              np.full(len(t), shelter, np.int32)))
                n += len(p)
        pos = np.concatenate([p[0] for p in parts])
        tris = np.concatenate([p[1] for p in parts])
        uvs = np.concatenate([p[2] for p in parts])
        mi = np.clip(np.concatenate([p[3] for p in parts]), 0, len(slots) - 1)
        sp = params["snow"]
        if settings.auto_volume:
            lo, hi = pos.min(axis=0), pos.max(axis=0)
            height = float(hi[2] - lo[2]) + 1.5
            wind = np.array(sp["wind"][:2], np.float64)
            drift = np.abs(wind) * height / max(sp["fall_speed"], 0.05)
            margin = 0.5 + drift
            sp["volume_min"] = (float(lo[0] - margin[0]), float(lo[1] - margin[1]),
                                float(lo[2]) - 0.05)
            sp["volume_max"] = (float(hi[0] + margin[0]), float(hi[1] + margin[1]),
                                float(hi[2]) + 1.5)
        fps = scene.render.fps / scene.render.fps_base
        substeps = max(1, int(round(1.0 / fps / sp["time_step"])))
        return params, dict(positions=pos, triangles=tris, uvs=uvs, material_index=mi,
                            materials=slots, substeps=substeps, flakes=settings.write_flakes)

    # --- wiring -------------------------------------------------------------------------
    BOX_UV = "HBK_SnowBox"

    @classmethod
    def _box_uvs(cls, obj, snow, slots):
        """The paper's projection back onto the model (§3.3.2) for BOX mode, as a UV map:
        each face takes the tile of its part's box that faces its normal's dominant axis, in
        the atlas layout of hbk_snow.h (a block per material slot, six tiles per block)."""
        mesh = obj.data
        m = np.array(obj.matrix_world, np.float64)
        co = np.empty(len(mesh.vertices) * 3)
        mesh.vertices.foreach_get("co", co)
        co = co.reshape(-1, 3) @ m[:3, :3].T + m[:3, 3]
        mi = np.array([p.material_index for p in mesh.polygons])
        lo = np.zeros((slots, 3))
        hi = np.ones((slots, 3))
        for b in range(slots):
            vs = [v for p in mesh.polygons if p.material_index == b for v in p.vertices]
            if vs:
                lo[b], hi[b] = co[vs].min(axis=0), co[vs].max(axis=0)
        size = np.maximum(hi - lo, 1e-9)
        w, h = snow.texture_width, snow.texture_height
        tw, th = w // 3, h // 2
        uv = mesh.uv_layers.get(cls.BOX_UV) or mesh.uv_layers.new(name=cls.BOX_UV)
        nrm = np.array([tuple(m[:3, :3] @ np.array(p.normal)) for p in mesh.polygons])
        for p, n, b in zip(mesh.polygons, nrm, mi):
            axis = int(np.argmax(np.abs(n)))
            pos = n[axis] > 0
            for li in p.loop_indices:
                q = (co[mesh.loops[li].vertex_index] - lo[b]) / size[b]
                u, v = {  # the face's (u, v) axes as hbk_snow.h lists them
                    (0, True): (q[1], q[2]), (0, False): (1 - q[1], q[2]),
                    (1, True): (1 - q[0], q[2]), (1, False): (q[0], q[2]),
                    (2, True): (q[0], q[1]), (2, False): (q[0], 1 - q[1])}[(axis, pos)]
                uv.data[li].uv = ((axis * tw + u * tw) / w,
                                  (b * h + (1 if pos else 0) * th + v * th) / (h * slots))
        return cls.BOX_UV

    @classmethod
    def apply(cls, context, obj, settings, folder, manifest):
        frames = sorted(int(f) for f in manifest["frames"])
        uv = obj.data.uv_layers.active.name if obj.data.uv_layers.active else ""
        if manifest["params"]["snow"]["contact_mode"] == 1:  # BOX: the atlas, not the UVs
            slots = len(obj.material_slots) + (1 if settings.colliders else 0)
            uv = cls._box_uvs(obj, settings.snow, max(slots, 1))
        for index in range(len(obj.material_slots)):
            mat = obj.material_slots[index].material
            if mat is None or not mat.use_nodes or mat.hydrobake_snow.melts or \
                    mat.hydrobake_snow.sheds:
                continue
            mat = materials.own(obj, index, _unwire)
            tree = mat.node_tree
            out = next((n for n in tree.nodes if n.type == "OUTPUT_MATERIAL" and
                        n.is_active_output), None)
            if out is None or not out.inputs["Surface"].is_linked:
                continue
            x, y = out.location
            uvn = materials.add_node(tree, "ShaderNodeUVMap", "snow.uv", (x - 900, y - 300))
            uvn.uv_map = uv
            cov = materials.add_node(tree, "ShaderNodeTexImage", "snow.coverage",
                                     (x - 700, y - 300))
            cov.image = images.load_sequence(folder, "coverage", frames[0], len(frames),
                                             name=f"HBK_{obj.name}_snow_coverage")
            images.configure_user(cov.image_user, frames[0], len(frames))
            tree.links.new(uvn.outputs["UV"], cov.inputs["Vector"])
            white = materials.add_node(tree, "ShaderNodeBsdfPrincipled", "snow.bsdf",
                                       (x - 450, y - 450))
            white.inputs["Base Color"].default_value = (0.92, 0.94, 0.97, 1.0)
            white.inputs["Roughness"].default_value = 0.75
            white.inputs["Subsurface"].default_value = 0.2
            white.inputs["Subsurface Color"].default_value = (0.8, 0.9, 1.0, 1.0)
            mix = materials.add_node(tree, "ShaderNodeMixShader", "snow.mix", (x - 200, y))
            surface = out.inputs["Surface"].links[0].from_socket
            if surface.node is not mix:
                tree.links.new(surface, mix.inputs[1])
            tree.links.new(cov.outputs["Alpha"], mix.inputs["Fac"])
            tree.links.new(white.outputs["BSDF"], mix.inputs[2])
            tree.links.new(mix.outputs["Shader"], out.inputs["Surface"])
            disp_in = out.inputs["Displacement"]
            ours = disp_in.is_linked and disp_in.links[0].from_node.get(materials.TAG) == \
                "snow.displacement"
            if settings.use_displacement and (ours or not disp_in.is_linked):  # re-bakes too
                dep = materials.add_node(tree, "ShaderNodeTexImage", "snow.depth",
                                         (x - 700, y - 600))
                dep.image = images.load_sequence(folder, "depth", frames[0], len(frames),
                                                 name=f"HBK_{obj.name}_snow_depth")
                images.configure_user(dep.image_user, frames[0], len(frames))
                tree.links.new(uvn.outputs["UV"], dep.inputs["Vector"])
                disp = materials.add_node(tree, "ShaderNodeDisplacement", "snow.displacement",
                                          (x - 300, y - 600))
                disp.inputs["Midlevel"].default_value = 0.0
                disp.inputs["Scale"].default_value = 1.0
                tree.links.new(dep.outputs["Color"], disp.inputs["Height"])
                tree.links.new(disp.outputs["Displacement"], out.inputs["Displacement"])

        if "flakes" in manifest.get("streams", []):
            white = bpy.data.materials.get("HBK Snow Flake") or _flake_material()
            points.attach(f"HBK_{obj.name}_flakes", folder, "flakes",
                          settings.snow.flake_radius * 2.0,
                          collection=obj.users_collection[0] if obj.users_collection else None,
                          material=white)

    @classmethod
    def remove(cls, context, obj, settings):
        frame_meshes.detach(f"HBK_{cls.baked_name(obj, settings)}_flakes")
        if obj.type == "MESH" and cls.BOX_UV in obj.data.uv_layers:
            obj.data.uv_layers.remove(obj.data.uv_layers[cls.BOX_UV])
        for slot in obj.material_slots:
            if slot.material is not None and slot.material.node_tree:
                _unwire(slot.material.node_tree)
        materials.restore(obj, "snow.")

    @classmethod
    def draw_settings(cls, layout, settings):
        col = layout.column()
        for name in ("colliders", "auto_volume", "use_displacement", "write_flakes"):
            col.prop(settings, name)
        super().draw_settings(layout, settings)


