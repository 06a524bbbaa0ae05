"""Caustics in Blender: the water object's plane is the simulation grid; the ground comes from
a mesh; an object moving through the surface disturbs it; the caustic sequence is multiplied
into the ground's material and the surface normals drive the water's material."""

import math
from collections import namedtuple

import bpy
import numpy as np
from mathutils import Vector

from ..bridge import animation, helper_objects, images, materials, meshes
from ..bridge.depsgraph import evaluated as evaluated_depsgraph
from . import register_effect
from .base import BlenderEffect, offers

HEIGHTS_OF = "hydrobake_heights_of"  # on a pool's height texture: the name it was baked as


def _height_textures(pool):
    """The height textures of the pool baked as ``pool``: by name, or renamed by the artist,
    by the record apply put on them."""
    return [t for t in bpy.data.textures
            if t.name == f"HBK_{pool}_height" or t.get(HEIGHTS_OF) == pool]


class Grid(namedtuple("Grid", "origin angle cell shape level")):
    """The water grid: ``origin`` the world (x, y) of its corner, ``angle`` its u axis's
    heading from world x (radians, about z), ``shape`` (rows, columns), ``level`` world z."""

    def to_grid(self, x, y):
        """World (x, y) to metres along the grid's u and v from its corner."""
        c, s = math.cos(self.angle), math.sin(self.angle)
        dx, dy = x - self.origin[0], y - self.origin[1]
        return c * dx + s * dy, -s * dx + c * dy

    def to_world(self, u, v):
        c, s = math.cos(self.angle), math.sin(self.angle)
        return self.origin[0] + c * u - s * v, self.origin[1] + s * u + c * v

    def direction(self, d):
        """A world direction in the grid's frame (the kernels' height-field frame)."""
        c, s = math.cos(self.angle), math.sin(self.angle)
        return c * d[0] + s * d[1], -s * d[0] + c * d[1], d[2]

    @property
    def size(self):
        return self.shape[1] * self.cell, self.shape[0] * self.cell


OWN_MODIFIERS = ("HBK Subdivision", "HBK Displace")


STREAM_IMAGES = ("view", "caustics", "surface", "height")  # HBK_<pool>_<stream>
FLOOR_ROLES = ("caustics.map", "caustics.multiply")  # (prefixes) of a floor's nodes


@offers("a mesh other than the water itself")
def _ground_poll(self, obj):
    return obj.type == "MESH" and obj != self.id_data


@offers("a mesh, curve, surface, text or metaball")
def _shaped_poll(_self, obj):
    return obj.type in animation.SHAPED_TYPES


@offers("a sun lamp")
def _sun_poll(_self, obj):
    return obj.type == "LIGHT" and obj.data.type == "SUN"


@offers("a camera")
def _camera_poll(_self, obj):
    return obj.type == "CAMERA"


@register_effect
class CausticsBlender(BlenderEffect):
    name = "caustics"
    label = "Caustics"
    wired_prefix, wired_streams = "caustics.", ("surface",)
    made_material = "water"
    icon = "MOD_OCEAN"
    refracts = True
    presets = {
        "Calm Pool": {"water": {"rain_rate": 0.0, "substeps": 4, "implicitness": 0.55},
                      "light": {"absorption": (0.0, 0.0, 0.0)}},
        "Rainy Pond": {"water": {"rain_rate": 40.0, "rain_radius": 0.04, "rain_depth": 0.01,
                                 "implicitness": 0.55},
                       "light": {"absorption": (0.35, 0.06, 0.01)}},
        "Dispersive": {"light": {"ior": (1.331, 1.333, 1.337),
                                 "absorption": (0.35, 0.06, 0.01), "fresnel": 1}},
    }

    @classmethod
    def extra_properties(cls):
        return dict(
            ground_object=bpy.props.PointerProperty(
                name="Ground", type=bpy.types.Object,
                poll=_ground_poll,
                description="Mesh under the water (pool floor, beach); its material gets the "
                            "caustics. Followed frame by frame when animated or deformed (the "
                            "water keeps its depth over it). Empty: flat ground 1 m below the "
                            "water"),
            ground_image=bpy.props.PointerProperty(
                name="Ground Image", type=bpy.types.Image,
                description="A height map of the ground over the water's extent (used when no "
                            "Ground mesh is set): value x Ground Image Scale, in metres below "
                            "the water level"),
            ground_image_scale=bpy.props.FloatProperty(
                name="Ground Image Scale", default=1.0, min=0.0, max=100.0, subtype="DISTANCE",
                unit="LENGTH", description="Depth in metres of a pixel value of 1"),
            source_object=bpy.props.PointerProperty(
                name="Source", type=bpy.types.Object, poll=_shaped_poll,
                description="Where water is poured in (or drained): the cells under this "
                            "object's footprint, followed frame by frame when it moves"),
            source_rate=bpy.props.FloatProperty(
                name="Source Rate", default=0.05, min=-10.0, max=10.0, subtype="NONE",
                unit="VELOCITY", description="Water added per second under the source, in "
                                             "metres of depth (negative drains)"),
            disturber_object=bpy.props.PointerProperty(
                name="Disturber", type=bpy.types.Object, poll=_shaped_poll,
                description="Object moving through the surface; its footprint pushes the water "
                            "every frame"),
            disturber_depth=bpy.props.FloatProperty(
                name="Disturber Depth", default=0.1, min=0.0, max=5.0, subtype="DISTANCE",
                unit="LENGTH", description="Deepest the disturber presses the surface down"),
            sun_object=bpy.props.PointerProperty(
                name="Sun", type=bpy.types.Object,
                poll=_sun_poll,
                description="Sun lamp giving the light direction (else the Light parameters)"),
            map_resolution=bpy.props.IntProperty(
                name="Map Resolution", default=1024, min=16, max=8192,
                description="Caustic map width in pixels (height follows the aspect)"),
            loop=bpy.props.BoolProperty(
                name="Loop", default=False,
                description="Make the baked range a seamless loop: the last frames cross-fade "
                            "the water into the state just before the first frame"),
            loop_blend=bpy.props.IntProperty(
                name="Loop Blend", default=12, min=1, max=10000,
                description="Frames at the end of the loop that cross-fade into its start"),
            preview_camera=bpy.props.PointerProperty(
                name="Preview Camera", type=bpy.types.Object,
                poll=_camera_poll,
                description="Also bake the paper's own rendering of the water seen from this "
                            "camera (view refraction onto the lit ground, sky reflection) as "
                            "a preview sequence"),
            ground_texture=bpy.props.PointerProperty(
                name="Ground Texture", type=bpy.types.Image,
                description="The ground's colour over the water's extent, for the preview"),
            environment=bpy.props.PointerProperty(
                name="Environment", type=bpy.types.Image,
                description="A latitude-longitude sky reflected by the water in the preview"),
            projector=bpy.props.BoolProperty(
                name="Light Projector", default=False,
                description="Also add a spot light above the water that projects the caustic "
                            "sequence (lights swimmers, walls and anything else in the pool); "
                            "removed by Free Bake"),
            projector_power=bpy.props.FloatProperty(
                name="Projector Power", default=500.0, min=0.0, max=1e6, subtype="POWER",
                unit="POWER", description="Power of the projector light"),
            displace_surface=bpy.props.BoolProperty(
                name="Displace Surface", default=False,
                description="Also move the water mesh by the baked heights (adds Subdivision "
                            "and Displace modifiers, removed by Free Bake)"),
        )

    @staticmethod
    def _corners(obj):
        """World corners of the water's box, without this effect's own Subdivision and
        Displace (the Displace moves the surface it would measure: a re-bake or a resume must
        see the grid the bake saw)."""
        ours = [m for m in obj.modifiers if m.name in OWN_MODIFIERS and m.show_viewport]
        for mod in ours:
            mod.show_viewport = False
        try:
            ev = obj.evaluated_get(evaluated_depsgraph()) if ours else obj
            return np.array([tuple(obj.matrix_world @ Vector(c)) for c in ev.bound_box])
        finally:
            for mod in ours:
                mod.show_viewport = True

    @classmethod
    def grid(cls, obj, width):
        """The water grid over ``obj``, turned with it: its u axis follows the object's own x
        as seen from above, so a pool turned about z is covered by its own rectangle, not by
        its bounding box (whose corners are not water)."""
        m = obj.matrix_world
        angle = math.atan2(m[1][0], m[0][0]) if math.hypot(m[0][0], m[1][0]) > 1e-9 else 0.0
        if abs(angle) < 1e-7:
            angle = 0.0
        corners = cls._corners(obj)
        c, s = math.cos(angle), math.sin(angle)
        u = c * corners[:, 0] + s * corners[:, 1]
        v = -s * corners[:, 0] + c * corners[:, 1]
        ex, ey = float(u.max() - u.min()), float(v.max() - v.min())
        if min(ex, ey) <= 1e-3 * max(ex, ey, 1e-9):  # on edge: only float noise across
            raise ValueError(f"{obj.name}: the water object must be a horizontal plane with an "
                             f"extent in x and y (it spans {ex:.3g} x {ey:.3g} m from above)")
        cell = ex / width
        rows = max(4, int(round(ey / cell)))
        u0, v0 = float(u.min()), float(v.min())
        origin = (c * u0 - s * v0, s * u0 + c * v0)
        return Grid(origin, angle, cell, (rows, width), float(corners[:, 2].max()))

    @classmethod
    def evaluated_inputs(cls, obj, settings):
        return [(role, o) for role, o in (("Ground", settings.ground_object),
                                          ("Disturber", settings.disturber_object),
                                          ("Source", settings.source_object)) if o is not None]

    @classmethod
    def wired_objects(cls, obj, settings):
        ground = settings.ground_object
        return [obj] + ([ground] if ground is not None and ground.type == "MESH" else [])

    @classmethod
    def prepare(cls, context, obj, settings, params, frames):
        scene = context.scene
        grid = cls.grid(obj, params["water"]["width"])
        origin, cell, shape, level = grid.origin, grid.cell, grid.shape, grid.level
        params["water"].update(height=shape[0], cell_size=cell)
        ground_path = {}
        if settings.ground_object:
            def ground_heights(dg):
                g = meshes.sample_heights(settings.ground_object, origin, cell, shape, "DOWN",
                                          dg, angle=grid.angle, role="Ground")
                g[np.isnan(g)] = level - 1.0 if np.all(np.isnan(g)) else np.nanmin(g)
                return g
            ground, ground_path = yield from animation.followed(
                context, settings.ground_object, frames, ground_heights)
        elif settings.ground_image is not None:
            px = images.pixels(settings.ground_image, role="Ground Image")[..., 0].astype(
                np.float64)
            ih, iw = px.shape
            yy = (np.arange(shape[0]) + 0.5) / shape[0] * ih - 0.5
            xx = (np.arange(shape[1]) + 0.5) / shape[1] * iw - 0.5
            x0 = np.clip(np.floor(xx).astype(int), 0, iw - 1)
            y0 = np.clip(np.floor(yy).astype(int), 0, ih - 1)
            x1, y1 = np.minimum(x0 + 1, iw - 1), np.minimum(y0 + 1, ih - 1)
            tx = np.clip(xx - x0, 0, 1)[None, :]
            ty = np.clip(yy - y0, 0, 1)[:, None]
            v = (px[np.ix_(y0, x0)] * (1 - tx) + px[np.ix_(y0, x1)] * tx) * (1 - ty) + \
                (px[np.ix_(y1, x0)] * (1 - tx) + px[np.ix_(y1, x1)] * tx) * ty
            ground = (level - settings.ground_image_scale * v).astype(np.float32)
        else:
            ground = np.full(shape, level - 1.0, np.float32)
        if settings.sun_object:
            d = settings.sun_object.matrix_world.to_quaternion() @ Vector((0, 0, 1))
            if d.z <= 0.01:  # grazing light spreads the map over the whole ground
                up = math.degrees(math.asin(max(-1.0, min(1.0, d.z))))
                raise ValueError(f"Sun: {settings.sun_object.name} is {up:.1f} degrees above the "
                                 "horizon; the light must come from at least 0.6 degrees above")
            params["light"]["light_direction"] = grid.direction(d)
        footprints = {}
        if settings.disturber_object:
            def footprint(_f):
                dg = evaluated_depsgraph(context)
                under = meshes.sample_heights(settings.disturber_object, origin, cell, shape,
                                              "UP", dg, angle=grid.angle, role="Disturber")
                # Only where the object crosses the surface: wholly under it, it moves no
                # surface (its top below the level).
                top = meshes.sample_heights(settings.disturber_object, origin, cell, shape,
                                            "DOWN", dg, angle=grid.angle, role="Disturber")
                under[~(np.nan_to_num(top, nan=-np.inf) >= level)] = np.nan
                press = np.clip(level - np.nan_to_num(under, nan=level), 0.0,
                                settings.disturber_depth).astype(np.float32)
                return press if press.any() else None
            footprints = yield from animation.per_frame(scene, frames[0], frames[1], footprint)
        sources, sources_path = None, {}
        if settings.source_object:
            def poured(dg):
                under = meshes.sample_heights(settings.source_object, origin, cell, shape, "UP",
                                              dg, angle=grid.angle, role="Source")
                return np.where(np.isnan(under), 0.0, settings.source_rate).astype(np.float32)
            sources, sources_path = yield from animation.followed(
                context, settings.source_object, frames, poured)
        w = settings.map_resolution
        inputs = dict(ground=ground.astype(np.float32), ground_path=ground_path, level=level,
                      footprints=footprints, sources=sources, sources_path=sources_path,
                      map_size=(w, max(1, int(round(w * shape[0] / shape[1])))))
        if settings.loop:
            inputs["loop"] = (frames[0], frames[1], settings.loop_blend)
        if settings.preview_camera is not None:
            if settings.ground_texture is None:
                raise ValueError("Ground Texture: the preview needs an image of the ground")
            cam = settings.preview_camera.matrix_world.translation
            if cam.z <= level:
                raise ValueError(f"Preview Camera: {settings.preview_camera.name} is at z = "
                                 f"{cam.z:.3g} m, not above the water (its surface at "
                                 f"{level:.3g} m)")
            inputs["view"] = {
                "heading": grid.angle,
                "camera": (*grid.to_grid(cam.x, cam.y), cam.z),
                "texture": np.ascontiguousarray(images.pixels(
                    settings.ground_texture, colour=True, role="Ground Texture")[..., :3]),
                "environment": None if settings.environment is None else
                np.ascontiguousarray(images.pixels(settings.environment, colour=True,
                                                   role="Environment")[..., :3])}
        return params, inputs

    # --- wiring -------------------------------------------------------------------------
    @classmethod
    def _sequence_texture(cls, tree, obj, grid, role, folder, stream, frames, location,
                          owner=None):
        """An image node playing ``stream``'s sequence, looked up by world position over the
        water grid (0..1 across the maps' extent)."""
        x, y = location
        geo = materials.add_node(tree, "ShaderNodeNewGeometry", f"{role}.position", (x - 400, y),
                                 owner=owner)
        mp = materials.add_node(tree, "ShaderNodeMapping", f"{role}.mapping", (x - 200, y),
                                owner=owner)
        # Texture mapping is the inverse transform: (R^T (position - corner)) / size.
        mp.vector_type = "TEXTURE"
        mp.inputs["Location"].default_value = (grid.origin[0], grid.origin[1], 0.0)
        mp.inputs["Rotation"].default_value = (0.0, 0.0, grid.angle)
        mp.inputs["Scale"].default_value = (*grid.size, 1.0)
        tree.links.new(geo.outputs["Position"], mp.inputs["Vector"])
        tex = materials.add_node(tree, "ShaderNodeTexImage", role, (x, y), owner=owner)
        tex.image = images.load_sequence(folder, stream, frames[0], len(frames),
                                         name=f"HBK_{obj.name}_{stream}")
        tex.extension = "EXTEND"
        images.configure_user(tex.image_user, frames[0], len(frames))
        tree.links.new(mp.outputs["Vector"], tex.inputs["Vector"])
        return tex

    @classmethod
    def apply(cls, context, obj, settings, folder, manifest):
        frames = sorted(int(f) for f in manifest["frames"])
        grid = cls.grid(obj, manifest["params"]["water"]["width"])
        ground = settings.ground_object
        if ground is not None and ground.type != "MESH":
            ground = None
        # The pool's floor nodes out of every material but the ground's (in any form): found
        # by their owner, as the ground wired last may have been renamed since (its name then
        # finds nothing, and it kept showing the caustics), or its material swapped out.
        old = bpy.data.objects.get(settings.get("wired_ground", ""))
        keep = materials.every_material(ground) if ground else set()
        cls._unwire_floors(obj.name, [old] if old not in (None, ground) else [], keep=keep)
        if ground is not None:
            cls._wire_floor(ground, obj, grid, folder, frames)
            settings["wired_ground"] = ground.name
        # The water: a clear refracting material with the baked surface normals (the pool's
        # own: another pool sharing the material has other normals).
        # Nodes on in the pool's own copy only: the shared material stays as it was.
        materials.ensure_material(obj, cls.made_material_name(obj.name), nodes=False)
        mat = materials.own(obj, 0, lambda tree: materials.remove_tagged(tree, "caustics."))
        materials.use_nodes(mat)
        tree = mat.node_tree
        bsdf = materials.principled(tree)
        if bsdf is not None:
            materials.set_inputs(mat, bsdf, {"Transmission": 1.0, "Roughness": 0.0,
                                             "IOR": 1.333}, "caustics.")
            materials.see_through(mat)
            tex = cls._sequence_texture(tree, obj, grid, "caustics.surface", folder,
                                        "surface", frames, (bsdf.location.x - 500, 0))
            nm = materials.add_node(tree, "ShaderNodeNormalMap", "caustics.normal",
                                    (bsdf.location.x - 200, -100))
            nm.space = "WORLD"
            tree.links.new(tex.outputs["Color"], nm.inputs["Color"])
            # The map's normals are in the grid's frame: turned with the grid into the world.
            turn = materials.add_node(tree, "ShaderNodeVectorRotate", "caustics.normal_turn",
                                      (bsdf.location.x - 100, -250))
            turn.rotation_type = "Z_AXIS"
            turn.inputs["Angle"].default_value = grid.angle
            tree.links.new(nm.outputs["Normal"], turn.inputs["Vector"])
            tree.links.new(turn.outputs["Vector"], bsdf.inputs["Normal"])
        # Off, what an earlier bake made for them goes: a Shift+D copy's copied Displace
        # read the original's heights, freed with it (monkey --more --delete-baked 7084), and
        # a script may change a baked pool's settings before a re-bake.
        if settings.displace_surface:
            cls._displace(obj, folder, frames, grid)
        else:
            cls._undisplace(obj, obj.name)
        if settings.projector:
            cls._projector(context, obj, settings, folder, frames, grid)
        else:
            cls._remove_helpers(obj.name, ("projector",))
        if "view" in manifest.get("streams", []):
            images.load_unused_sequence(folder, "view", frames[0], len(frames),
                                        f"HBK_{obj.name}_view")
        # Light reaches the floor through the caustic map, not through the glass: the water
        # casts no shadow (restored by Free Bake).
        if "hydrobake_shadow" not in obj:
            obj["hydrobake_shadow"] = int(obj.visible_shadow)
        obj.visible_shadow = False

    @classmethod
    def _wire_floor(cls, ground, obj, grid, folder, frames):
        """Multiplies the pool's caustic map into the base colour of every material of the
        ground (the ones its slots render with). Each pool under one ground has its own nodes
        (owned by the pool) and its own multiply in a chain, so a second pool adds its map
        rather than taking the first one's place."""
        mats = list(dict.fromkeys(s.material for s in ground.material_slots if s.material))
        for mat in mats or [materials.ensure_material(ground, f"HBK_{ground.name}_floor")]:
            materials.use_nodes(mat)
            cls._wire_floor_material(mat.node_tree, obj, grid, folder, frames)

    @classmethod
    def _wire_floor_material(cls, tree, obj, grid, folder, frames):
        bsdf = materials.principled(tree)
        if bsdf is None:
            return
        owner = obj.name
        x = bsdf.location.x
        tex = cls._sequence_texture(tree, obj, grid, "caustics.map", folder, "caustics",
                                    frames, (x - 500, 300), owner=owner)
        # The colour is read past the water's edge (EXTEND) and the alpha clipped there (the
        # floor beyond keeps its own colour): one clipped lookup for both blends the edge
        # texel's colour with black, a dark line one map texel wide around the pool.
        edge = materials.add_node(tree, "ShaderNodeTexImage", "caustics.map_edge",
                                  (x - 500, 550), owner=owner)
        edge.image, edge.extension = tex.image, "CLIP"
        images.configure_user(edge.image_user, frames[0], len(frames))
        tree.links.new(tex.inputs["Vector"].links[0].from_socket, edge.inputs["Vector"])
        mix = materials.add_node(tree, "ShaderNodeMixRGB", "caustics.multiply", (x - 250, 200),
                                 owner=owner)
        mix.blend_type = "MULTIPLY"
        tree.links.new(edge.outputs["Alpha"], mix.inputs["Fac"])
        tree.links.new(tex.outputs["Color"], mix.inputs["Color2"])
        base = bsdf.inputs["Base Color"]
        socket = base  # up the chain of multiplies already feeding the base colour
        while socket.is_linked and socket.links[0].from_node.get(materials.TAG) == \
                "caustics.multiply":
            if socket.links[0].from_node == mix:
                return  # a re-bake: already in the chain
            socket = socket.links[0].from_node.inputs["Color1"]
        if base.is_linked:
            tree.links.new(base.links[0].from_socket, mix.inputs["Color1"])
        else:
            mix.inputs["Color1"].default_value = base.default_value
        tree.links.new(mix.outputs["Color"], base)

    @classmethod
    def _unwire_floors(cls, pool, grounds, keep=()):
        """Takes the pool's floor nodes out of every material but those in ``keep`` (its
        ground may have been changed or deleted since the bake), and nodes from before they
        had owners out of its grounds' materials; gives the grounds' materials back."""
        floors = {s.material for g in grounds for s in g.material_slots if s.material}
        unwired = []
        for mat in bpy.data.materials:
            if not mat.node_tree or mat in keep:
                continue
            tree = mat.node_tree
            for owner in (pool, None) if mat in floors else (pool,):
                mix = materials.tagged(tree, "caustics.multiply", owner)
                if mix is not None:
                    cls._unwire_multiply(tree, mix)
                # Of the nodes without an owner, the floor's only: a water's surface has none
                # either, and a baked pool's material given to the ground keeps its bake
                # (Join, Link Materials: monkey every flag + --relations 41).
                roles = ("caustics.",) if owner is not None else FLOOR_ROLES
                if sum(materials.remove_tagged(tree, r, owner=owner) for r in roles):
                    unwired.append(mat)
        for g in dict.fromkeys(grounds):
            for mat in {s.material for s in g.material_slots if s.material} - set(keep):
                materials.give_back(g, mat, "caustics.")
        # A floor material made for a ground that was given another one since (monkey 312),
        # or hidden behind a slot's Link since (--more 1030): out of the grounds, and gone;
        # one the artist took off the ground gets its node switch and values back (1033).
        gone = [m for m in dict.fromkeys(unwired) if m not in floors]
        materials.take_out_made(gone, grounds)
        for mat in gone:
            materials.give_back(None, mat, "caustics.")

    @staticmethod
    def _unwire_multiply(tree, mix):
        """Takes a pool's multiply out of the chain: what fed it feeds what it fed."""
        c1 = mix.inputs["Color1"]
        for link in list(mix.outputs["Color"].links):
            if c1.is_linked:
                tree.links.new(c1.links[0].from_socket, link.to_socket)
            else:
                link.to_socket.default_value = c1.default_value

    @classmethod
    def _displace(cls, obj, folder, frames, grid):
        """Subdivision + Displace modifiers reading the height sequence at each vertex's place
        on the water grid: the texture coordinates of an Empty spanning the grid (-1..1 is the
        image), so vertices other modifiers make (a Mirror, an Array) read their own place.
        All made here, removed by Free Bake."""
        shape = grid.shape
        mesh = obj.data
        frame = helper_objects.find("caustics", obj.name, "grid", "EMPTY") or \
            bpy.data.objects.new(f"HBK_{obj.name}_grid", None)
        helper_objects.tag(frame, "caustics", obj.name, "grid")
        if frame.name not in bpy.context.scene.collection.all_objects:
            (obj.users_collection[0] if obj.users_collection else
             bpy.context.scene.collection).objects.link(frame)
        w, h = grid.size
        frame.location = (*grid.to_world(w / 2, h / 2), 0.0)
        frame.rotation_euler = (0.0, 0.0, grid.angle)
        frame.scale = (w / 2, h / 2, 1.0)
        frame.empty_display_type, frame.hide_render = "PLAIN_AXES", True
        frame.hide_viewport = True
        sub, disp = cls._modifiers(obj, obj.name)
        # The Displace's texture (renamed, maybe), unless another modifier reads it too: a
        # Shift+D copy's Displace shares the original's, whose water would move with the
        # copy's waves (monkey --scene --external 1031).
        tex = (disp.texture if disp is not None and disp.texture is not None and
               disp.texture.type == "IMAGE" and disp.texture.users == 1 else None) or \
            bpy.data.textures.get(f"HBK_{obj.name}_height") or \
            bpy.data.textures.new(f"HBK_{obj.name}_height", "IMAGE")
        tex[HEIGHTS_OF] = obj.name  # (found by it, renamed, with the grid deleted)
        tex.image = images.load_sequence(folder, "height", frames[0], len(frames),
                                         name=f"HBK_{obj.name}_height")
        tex.extension = "EXTEND"
        tex.use_clamp = False  # heights below the level are negative: the water goes down too
        images.configure_user(tex.image_user, frames[0], len(frames))
        sub = sub or obj.modifiers.new("HBK Subdivision", "SUBSURF")
        sub.subdivision_type = "SIMPLE"
        # Enough levels for about a face per grid cell from the faces the mesh already has
        # (each level makes four of one): a dense mesh subdivided as a plane was tens of
        # millions of faces.
        need = shape[0] * shape[1] / max(len(mesh.polygons), 1)
        sub.levels = sub.render_levels = min(6, max(0, int(np.ceil(np.log(max(need, 1.0)) /
                                                                  np.log(4.0)))))
        disp = disp or obj.modifiers.new("HBK Displace", "DISPLACE")
        disp.texture = tex
        disp.texture_coords = "OBJECT"
        disp.texture_coords_object = frame
        disp.direction = "Z"
        disp.space = "GLOBAL"  # heights are world metres
        disp.mid_level = 0.0
        disp.strength = 1.0

    @classmethod
    def _projector(cls, context, obj, settings, folder, frames, grid):
        """A spot light straight above the grid's centre whose emission is the caustic map,
        projected so that the map spans the grid at the ground's mean depth (a gobo)."""
        level = grid.level
        sx, sy = grid.size
        ground = settings.ground_object
        floor = (meshes.world_bounds(ground)[0][2] + meshes.world_bounds(ground)[1][2]) / 2 \
            if ground is not None else level - 1.0
        height = max(sx, sy)  # far enough for a narrow, even cone
        name = f"HBK_{obj.name}_projector"
        lobj = helper_objects.find("caustics", obj.name, "projector", "LIGHT")
        if lobj is None:
            light = bpy.data.lights.get(name) or bpy.data.lights.new(name, "SPOT")
            lobj = bpy.data.objects.new(name, light)
        lobj.data.type = "SPOT"  # (an artist may have made it another kind)
        light = lobj.data  # the one it shows, renamed or not
        helper_objects.tag(lobj, "caustics", obj.name, "projector")
        if lobj.name not in context.scene.collection.all_objects:
            (obj.users_collection[0] if obj.users_collection else
             context.scene.collection).objects.link(lobj)
        lobj.location = (*grid.to_world(sx / 2, sy / 2), level + height)
        # A spot light points down its -Z; turned with the grid, its x runs along the map's.
        lobj.rotation_euler = (0.0, 0.0, grid.angle)
        dist = level + height - floor
        light.energy = settings.projector_power
        light.spot_size = 2.0 * np.arctan(0.5 * np.hypot(sx, sy) / dist) * 1.05
        light.spot_blend = 0.0
        light.shadow_soft_size = 0.0
        light.use_nodes = True
        tree = light.node_tree
        for n in list(tree.nodes):
            if n.type not in ("OUTPUT_LIGHT", "EMISSION"):
                tree.nodes.remove(n)
        emit = next(n for n in tree.nodes if n.type == "EMISSION")
        coord = tree.nodes.new("ShaderNodeTexCoord")
        sep = tree.nodes.new("ShaderNodeSeparateXYZ")
        tree.links.new(coord.outputs["Normal"], sep.inputs["Vector"])
        uv = []
        for axis, size in (("X", sx), ("Y", sy)):
            div = tree.nodes.new("ShaderNodeMath")
            div.operation = "DIVIDE"
            tree.links.new(sep.outputs[axis], div.inputs[0])
            tree.links.new(sep.outputs["Z"], div.inputs[1])
            mad = tree.nodes.new("ShaderNodeMath")
            mad.operation = "MULTIPLY_ADD"  # u = (x / z) * (-dist / size) + 0.5
            tree.links.new(div.outputs[0], mad.inputs[0])
            mad.inputs[1].default_value = -dist / size
            mad.inputs[2].default_value = 0.5
            uv.append(mad)
        comb = tree.nodes.new("ShaderNodeCombineXYZ")
        tree.links.new(uv[0].outputs[0], comb.inputs["X"])
        tree.links.new(uv[1].outputs[0], comb.inputs["Y"])
        tex = tree.nodes.new("ShaderNodeTexImage")
        tex.image = images.load_sequence(folder, "caustics", frames[0], len(frames),
                                         name=f"HBK_{obj.name}_caustics")
        tex.extension = "CLIP"
        images.configure_user(tex.image_user, frames[0], len(frames))
        tree.links.new(comb.outputs["Vector"], tex.inputs["Vector"])
        tree.links.new(tex.outputs["Color"], emit.inputs["Color"])

    @staticmethod
    def _modifiers(obj, pool):
        """(Subdivision, Displace) apply gave the pool baked as ``pool``, or None each: by
        their names, else (renamed by the artist) the Displace reading the pool's heights or
        grid, else one reading another pool's heights (a Shift+D copy's, renamed before the
        copy), and the simple Subdivision just before it. Not found, a re-bake would add a
        second pair: the water subdivided twice over, and displaced twice (a copy's by the
        original's heights too, left reading them once they were freed: monkey 790)."""
        mods = list(obj.modifiers)
        disp = obj.modifiers.get("HBK Displace")
        if disp is None:
            grids = helper_objects.every("caustics", pool, "grid", "EMPTY")
            heights = _height_textures(pool)
            disp = next((m for m in mods if m.type == "DISPLACE" and (
                (m.texture is not None and m.texture in heights) or
                (m.texture_coords_object is not None and m.texture_coords_object in grids))),
                None) or next((m for m in mods if m.type == "DISPLACE" and
                               m.texture is not None and m.texture.get(HEIGHTS_OF)), None)
        sub = obj.modifiers.get("HBK Subdivision")
        if sub is None and disp is not None and mods.index(disp) > 0:
            before = mods[mods.index(disp) - 1]
            if before.type == "SUBSURF" and before.subdivision_type == "SIMPLE":
                sub = before
        return sub, disp

    @classmethod
    def _remove_modifiers(cls, obj, pool):
        """Takes the pair out; returns the Displace's texture (_undisplace removes it once
        unused)."""
        sub, disp = cls._modifiers(obj, pool)
        tex = disp.texture if disp is not None else None
        for mod in (disp, sub):
            if mod is not None:
                obj.modifiers.remove(mod)
        return tex

    @classmethod
    def _undisplace(cls, obj, pool):
        """The Subdivision and Displace modifiers, and the height texture and grid Empty of
        the pool baked as ``pool`` once nothing uses them."""
        tex = cls._remove_modifiers(obj, pool)
        image = getattr(tex, "image", None)
        if image is None or not image.name.startswith("HBK_"):
            tex = None  # (the artist's, given to the Displace since)
        for height in {tex, *_height_textures(pool)} - {None}:
            if height.users == 0:
                bpy.data.textures.remove(height)
        for grid in helper_objects.every("caustics", pool, "grid", "EMPTY"):
            if not any(m.type == "DISPLACE" and m.texture_coords_object == grid
                       for o in bpy.data.objects for m in o.modifiers):
                bpy.data.objects.remove(grid)

    @classmethod
    def let_go(cls, context, obj, settings, keep):
        cls._remove_modifiers(obj, cls.baked_name(obj, settings))
        for mat in cls.slot_materials(obj, settings) - set(keep):
            if mat.node_tree:
                materials.remove_tagged(mat.node_tree, "caustics.")
            materials.give_back(obj, mat, "caustics.")
        materials.restore(obj, "caustics.")
        cls._give_shadow_back(obj)

    @staticmethod
    def _give_shadow_back(obj):
        if "hydrobake_shadow" in obj:
            obj.visible_shadow = bool(obj["hydrobake_shadow"])
            del obj["hydrobake_shadow"]

    @classmethod
    def forget_deleted_floors(cls):
        """Takes the floors' wiring of pools deleted while baked (not freed first) out of the
        floors, with the pools' projector, grid and images: no object records those pools
        now. Their files stay, as any deleted object's bake; undo brings pool and wiring
        back together (measured in the UI). Returns the pools' names."""
        gone = cls.deleted_bakes(cls._floor_owners() | cls._helper_owners())
        for pool in sorted(gone):
            cls._forget_floors(pool)
        return gone

    @staticmethod
    def _helper_owners():
        """The pools whose projector or grid Empty (apply's helper objects, by name or tag) is
        in the file: with the ground deleted first, they are all a deleted pool leaves
        (monkey --more --delete-baked 7076, 7077)."""
        helpers = [(o.name, o.type) for o in bpy.data.objects] + \
            [(light.name, "LIGHT") for light in bpy.data.lights]
        return {name[4:-len(suffix)] for name, kind in helpers
                for suffix, want in (("_projector", "LIGHT"), ("_grid", "EMPTY"))
                if kind == want and name.startswith("HBK_") and name.endswith(suffix)} | \
            helper_objects.owners("caustics", ("projector", "grid"))

    @staticmethod
    def _floor_owners():
        return {n.get(materials.OWNER) for m in bpy.data.materials if m.node_tree
                for n in m.node_tree.nodes
                if str(n.get(materials.TAG, "")).startswith("caustics.")} - {None}

    @classmethod
    def _forget_floors(cls, pool):
        grounds = [o for o in bpy.data.objects if any(
            s.material and s.material.node_tree and
            materials.tagged(s.material.node_tree, "caustics.map", pool)
            for s in o.material_slots)]
        cls._unwire_floors(pool, grounds)
        # Clean copies of a floor material that waters kept while the pool's floor nodes were
        # in it: the floor material back (monkey --more --delete-baked 1620).
        materials.put_back_others("caustics.")
        cls._remove_helpers(pool)
        for stream in STREAM_IMAGES:  # those nothing shows any more
            images.remove(f"HBK_{pool}_{stream}")

    @classmethod
    def wired_names(cls):
        """The pools the floors' nodes are for, those whose surface a water shows, and those
        whose helper objects are in the file."""
        return cls._floor_owners() | cls.shown_in() | cls._helper_owners()

    @classmethod
    def forget(cls, pool):
        """The floors' wiring, the water's (in the material the pool left), the projector,
        grid and images."""
        materials.forget(pool, "caustics.", {f"HBK_{pool}_surface"},
                         lambda tree: materials.remove_tagged(tree, "caustics.", owner=None))
        for height in _height_textures(pool):  # the pool's Displace's
            if height.users == 0:
                bpy.data.textures.remove(height)  # (first: its image goes with the others)
        cls._forget_floors(pool)

    @staticmethod
    def _remove_helpers(pool, which=("projector", "grid")):
        """The pool's projector (and its light) and its grid object, renamed or not."""
        lights = {bpy.data.lights.get(f"HBK_{pool}_projector")}
        for role, kind in (("projector", "LIGHT"), ("grid", "EMPTY")):
            if role in which:
                for helper in helper_objects.every("caustics", pool, role, kind):
                    lights.add(helper.data)
                    bpy.data.objects.remove(helper)
        for light in lights - {None}:
            if light.users == 0:
                bpy.data.lights.remove(light)

    @classmethod
    def after_deletes(cls):
        cls.forget_deleted_floors()

    @classmethod
    def register_extra(cls):
        bpy.app.handlers.save_pre.append(_before_save)

    @classmethod
    def unregister_extra(cls):
        if _before_save in bpy.app.handlers.save_pre:
            bpy.app.handlers.save_pre.remove(_before_save)

    @classmethod
    def remove(cls, context, obj, settings):
        pool = cls.baked_name(obj, settings)
        prefix = f"HBK_{pool}"
        cls._undisplace(obj, pool)  # (first: a renamed Displace is known by the grid)
        cls._remove_helpers(pool)
        if obj.type == "MESH" and obj.data.uv_layers.get("HBK_UV"):  # from older bakes
            obj.data.uv_layers.remove(obj.data.uv_layers["HBK_UV"])
        # The water's wiring wherever it is: in the pool's slots, and in materials taken out
        # of them since (or a shared one a re-bake made a copy of), known by its images.
        for mat in cls.slot_materials(obj, settings):
            if mat.node_tree:
                materials.remove_tagged(mat.node_tree, "caustics.")
            materials.give_back(obj, mat, "caustics.")
        for mat in materials.holding("caustics.", {f"{prefix}_surface"}, owner=None):
            materials.remove_tagged(mat.node_tree, "caustics.", owner=None)
            materials.give_back(obj, mat, "caustics.")
        grounds = [g for g in (settings.ground_object,
                               bpy.data.objects.get(settings.get("wired_ground", "")))
                   if g is not None and g.type == "MESH"]
        cls._unwire_floors(pool, grounds)
        # After the floors: the ground may be another pool showing the shared material this
        # pool's clean copy stands for (monkey 312).
        materials.restore(obj, "caustics.", made=cls.made_material_name(pool))
        settings.pop("wired_ground", None)
        cls._give_shadow_back(obj)
        for stream in STREAM_IMAGES:
            images.remove(f"{prefix}_{stream}")

    @classmethod
    def draw_settings(cls, layout, settings):
        col = layout.column()
        for name in ("ground_object", "ground_image", "ground_image_scale", "source_object",
                     "source_rate", "disturber_object", "disturber_depth", "sun_object",
                     "map_resolution", "loop", "loop_blend", "displace_surface", "projector",
                     "projector_power", "preview_camera", "ground_texture", "environment"):
            col.prop(settings, name)
        super().draw_settings(layout, settings)




@bpy.app.handlers.persistent
def _before_save(*_args):
    """A script may delete a pool and save with no update between."""
    CausticsBlender.forget_deleted_floors()
