"""Snow in Blender: the object's evaluated mesh (moved and deformed by its animation over the
bake's frames, its faces as at the first; its active UV map, or in BOX mode a projection of
its own) is the target; objects in a collider collection shelter it; each material says how
well it catches snow and whether it melts or sheds flakes. The coverage and depth sequences
are mixed into every material of the object non-destructively (Free Bake takes them out
again)."""
import math
import warnings

import bpy
import numpy as np
from mathutils import Vector

from ..bridge import animation, frame_meshes, helper_objects, images, materials, mesh_data, \
    points
from ..bridge.depsgraph import evaluated as evaluated_depsgraph
from . import register_effect
from .base import BakeWarning, BlenderEffect, warn_uv_overlap

# Flakes per cubic metre of the C default: 200 000 in its 4 x 4 x 4 m volume. Auto Volume
# keeps the density, not the count, so a house gets as much snow per square metre as a car.
DEFAULT_DENSITY = 200000 / 64.0

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


STREAMS = ("snow_coverage", "snow_depth")  # the images apply wires: HBK_<name>_<stream>

# An empty slot 0 gets a new node material from Bake (ensure_material), whose Principled BSDF
# has Blender's default roughness 0.5 and metallic 0: the slot catches what that one will.
EMPTY_SLOT_CATCH = 0.5 * 0.5 * (1.0 - 0.0)


def catch_of(mat):
    if mat is None:
        return EMPTY_SLOT_CATCH, False, False
    s = mat.hydrobake_snow
    if s.catch == "CUSTOM":
        c = s.catch_chance
    elif s.catch == "ROUGHNESS":
        # Nodes Bake turned on (use_nodes) in the user's material hold a default Principled
        # BSDF: the material is still the one its viewport values describe, as before the
        # first bake. (One Bake made has nothing else: its Principled BSDF it is.)
        nodes = mat.use_nodes and mat.node_tree and (
            materials.NODES_WERE_OFF not in mat or materials.MADE in mat)
        bsdf = materials.principled(mat.node_tree) if nodes else None
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


def _detach_flakes(name):
    """The falling flakes of the bake wired as ``name``, renamed or not."""
    for flakes in helper_objects.every("snow", name, "flakes", "MESH"):
        points.detach(flakes.name)


def _is_box(contact_mode):
    """Contact Mode BOX, as the settings (1) or an override ("BOX") give it."""
    return contact_mode == 1 or str(contact_mode).upper() == "BOX"


def _may_deform(obj):
    """animation.may_deform, but BOX mode's own modifier moves no vertex."""
    return animation.may_deform(obj, skip=SnowBlender._box_modifier(obj))


def _corners(points):
    """The 8 corners of the bounding box of (N, 3) points."""
    lo, hi = points.min(axis=0), points.max(axis=0)
    return np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1])
                     for z in (lo[2], hi[2])], np.float64)


def _unwire(tree):
    """Takes the snow out of a material: its surface shader back where the mix was."""
    mix = materials.tagged(tree, "snow.mix")
    if mix is not None and mix.inputs[1].is_linked:
        src = mix.inputs[1].links[0].from_socket
        for link in list(mix.outputs["Shader"].links):
            tree.links.new(src, link.to_socket)
    materials.remove_tagged(tree, "snow.")


class _Nodes:
    """Builds a node tree by expressions: each call adds a node and returns its (first enabled)
    output socket; an argument is a socket to link or a value to set."""

    def __init__(self, tree):
        self.tree = tree

    def node(self, idname, *args, **props):
        n = self.tree.nodes.new(idname)
        for k, v in props.items():
            setattr(n, k, v)
        ins = [s for s in n.inputs if s.enabled]
        for sock, a in zip(ins, args):
            if isinstance(a, bpy.types.NodeSocket):
                self.tree.links.new(a, sock)
            else:
                sock.default_value = a
        return n

    def __call__(self, idname, *args, **props):
        return next(s for s in self.node(idname, *args, **props).outputs if s.enabled)

    def math(self, op, a, b):
        return self("ShaderNodeMath", a, b, operation=op)

    def vmath(self, op, a, b=(0.0, 0.0, 0.0)):
        return self("ShaderNodeVectorMath", a, b, operation=op)

    def compare(self, op, a, b):
        return self("FunctionNodeCompare", a, b, data_type="FLOAT", operation=op)

    def boolean(self, op, a, b):
        return self("FunctionNodeBooleanMath", a, b, operation=op)

    def switch(self, kind, cond, if_false, if_true):
        return self("GeometryNodeSwitch", cond, if_false, if_true, input_type=kind)

    def separate(self, v):
        return [s for s in self.node("ShaderNodeSeparateXYZ", v).outputs]

    def combine(self, x, y, z):
        return self("ShaderNodeCombineXYZ", x, y, z)

    def transform(self, v, m, offset=None):
        """m (3 x 3 or more) @ v (+ offset)."""
        out = self.combine(*[self.vmath("DOT_PRODUCT", v, tuple(map(float, m[k][:3])))
                             for k in range(3)])
        return out if offset is None else self.vmath("ADD", out, tuple(map(float, offset)))


def _box_nodes(group, attr, matrix, normal_matrix, lo, inv_size, tile_u, tile_v):
    """Fills ``group`` (Geometry Nodes) with BOX mode's projection, as hbk_snow.h lays the
    atlas out: a face corner's world position (``matrix`` @ local) in its slot's box
    (``lo``, ``inv_size`` per slot), on the tile its world normal (``normal_matrix`` @
    local) points to most; stored as the corner attribute ``attr`` = (u, v, 0).
    ``tile_u``, ``tile_v``: a tile's share of a block's width and height."""
    tree = group
    tree.nodes.clear()
    if not tree.inputs:
        tree.inputs.new("NodeSocketGeometry", "Geometry")
    if not tree.outputs:
        tree.outputs.new("NodeSocketGeometry", "Geometry")
    N = _Nodes(tree)
    slots = len(lo)
    geo_in = N("NodeGroupInput")
    world = N.transform(N("GeometryNodeInputPosition"), matrix, matrix[:3, 3])
    face_normal = N("GeometryNodeFieldOnDomain", N("GeometryNodeInputNormal"), domain="FACE",
                    data_type="FLOAT_VECTOR")
    normal = N.transform(face_normal, normal_matrix)
    b = N.math("MINIMUM", N.math("MAXIMUM", N("GeometryNodeInputMaterialIndex"), 0.0),
               float(slots - 1))  # as prepare clips it
    box_lo, box_inv = tuple(lo[0]), tuple(inv_size[0])
    for k in range(1, slots):
        here = N.compare("EQUAL", b, float(k))
        box_lo = N.switch("VECTOR", here, box_lo, tuple(lo[k]))
        box_inv = N.switch("VECTOR", here, box_inv, tuple(inv_size[k]))
    qx, qy, qz = N.separate(N.vmath("MULTIPLY", N.vmath("SUBTRACT", world, box_lo), box_inv))
    ax, ay, az = N.separate(N.vmath("ABSOLUTE", normal))
    nx, ny, nz = N.separate(normal)
    # The dominant axis, the first of equals (as numpy's argmax): x, else y, else z.
    is_x = N.boolean("AND", N.compare("GREATER_EQUAL", ax, ay),
                     N.compare("GREATER_EQUAL", ax, az))
    is_y = N.boolean("NIMPLY", N.compare("GREATER_EQUAL", ay, az), is_x)
    up = N.compare("GREATER_THAN", N.switch("FLOAT", is_x, N.switch("FLOAT", is_y, nz, ny),
                                            nx), 0.0)
    # The face's (u, v) axes as hbk_snow.h lists them: +X (+Y, +Z), -X (-Y, +Z), +Y (-X, +Z),
    # -Y (+X, +Z), +Z (+X, +Y), -Z (+X, -Y).
    ux = N.switch("FLOAT", up, N.math("SUBTRACT", 1.0, qy), qy)  # also v on the Z faces
    uy = N.switch("FLOAT", up, qx, N.math("SUBTRACT", 1.0, qx))
    u = N.switch("FLOAT", is_x, N.switch("FLOAT", is_y, qx, uy), ux)
    v = N.switch("FLOAT", N.boolean("OR", is_x, is_y), ux, qz)
    column = N.switch("FLOAT", is_x, N.switch("FLOAT", is_y, 2.0, 1.0), 0.0)
    atlas = N.combine(N.math("MULTIPLY", N.math("ADD", column, u), tile_u),
                      N.math("DIVIDE", N.math("ADD", b, N.math("MULTIPLY", N.math(
                          "ADD", up, v), tile_v)), float(slots)), 0.0)
    store = N("GeometryNodeStoreNamedAttribute", geo_in, attr, data_type="FLOAT_VECTOR",
              domain="CORNER")
    tree.links.new(atlas, next(s for s in store.node.inputs if s.enabled and
                               s.type == "VECTOR"))
    N.node("NodeGroupOutput", store)


def auto_volume(lo, hi, wind, fall_speed):
    """The Auto Volume around the world box lo..hi: 1.5 m above it, widened 0.5 m and upwind
    by how far the wind carries a flake while it falls that height."""
    height = float(hi[2] - lo[2]) + 1.5
    margin = 0.5 + np.abs(np.array(wind[:2], np.float64)) * height / max(fall_speed, 0.05)
    return ((float(lo[0] - margin[0]), float(lo[1] - margin[1]), float(lo[2]) - 0.05),
            (float(hi[0] + margin[0]), float(hi[1] + margin[1]), float(hi[2]) + 1.5))


def estimate(obj, settings):
    """(flakes, volume size) Auto Volume would give at the current frame, from the bounding
    boxes of the object and its colliders (cheap enough for the panel; the bake measures the
    evaluated meshes over its frames, which a moving object widens)."""
    parts = [obj] + [o for o in (settings.colliders.all_objects if settings.colliders else ())
                     if o.type == "MESH" and o != obj]
    corners = np.array([tuple(o.matrix_world @ Vector(c)) for o in parts for c in o.bound_box])
    lo, hi = auto_volume(corners.min(axis=0), corners.max(axis=0), settings.snow.wind,
                         settings.snow.fall_speed)
    size = [b - a for a, b in zip(lo, hi)]
    return round(settings.flake_density * size[0] * size[1] * size[2]), size


def _flake_count(obj, density, lo, hi, most):
    """Flake Density x the Auto Volume, within the kernel's flake_count range (at most most)."""
    size = [b - a for a, b in zip(lo, hi)]
    volume = size[0] * size[1] * size[2]
    count = round(density * volume)
    if count > most:
        raise ValueError(
            f"{obj.name}: Flake Density {density:g} per m³ fills the Auto Volume "
            f"({size[0]:.1f} x {size[1]:.1f} x {size[2]:.1f} m = {volume:.0f} m³) with "
            f"{count} flakes; the most is {most}: set Flake Density at most "
            f"{math.floor(most / volume * 100) / 100:g}, or turn off Auto Volume and set a "
            "smaller volume")
    return max(1, count)


@register_effect
class SnowBlender(BlenderEffect):
    name = "snow"
    label = "Snow"
    wired_prefix, wired_streams = "snow.", STREAMS
    made_material = "snow"
    icon = "FREEZE"
    presets = {
        "Wet Snow (+1 °C)": {"snow": {"temperature": 1.0, "fall_speed": 1.2},
                             "flake_density": DEFAULT_DENSITY},
        "Powder (-8 °C)": {"snow": {"temperature": -8.0, "fall_speed": 0.7,
                                    "flutter_amplitude": 0.4},
                           "flake_density": DEFAULT_DENSITY},
        "Blizzard": {"snow": {"temperature": -4.0, "wind": (6.0, 0.0, 0.0),
                              "flake_count": 1000000}, "flake_density": 5 * DEFAULT_DENSITY},
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
                            "upwind so wind-blown flakes reach it; Flake Density then sets "
                            "how many flakes fall in it"),
            flake_density=bpy.props.FloatProperty(
                name="Flake Density", default=DEFAULT_DENSITY, min=0.01, max=1e6,
                soft_min=1.0, soft_max=50000.0, precision=0,
                description="Flakes per cubic metre of the Auto Volume (the flake count is "
                            "this times the volume), so snowfall per square metre does not "
                            "depend on the object's size; 3125 is the paper's default, a "
                            "blizzard about 15000"),
            use_displacement=bpy.props.BoolProperty(
                name="Displacement", default=True,
                description="Displace the surface by the baked snow depth"),
            write_flakes=bpy.props.BoolProperty(
                name="Flakes as Points", default=False,
                description="Also bake the falling flakes' positions per frame"),
        )

    @classmethod
    def evaluated_inputs(cls, obj, settings):
        colliders = settings.colliders.all_objects if settings.colliders else ()
        return [(None, obj)] + [("Colliders", o) for o in colliders
                                if o.type == "MESH" and o != obj]

    @classmethod
    def prepare(cls, context, obj, settings, params, frames):
        scene = context.scene
        dg = evaluated_depsgraph(context)
        sp = params["snow"]
        box = _is_box(sp["contact_mode"])
        pos, tris, uvs, mi = mesh_data.triangles(obj, dg, world=False)
        if uvs is None:
            if not box:
                raise ValueError(f"{obj.name}: needs a UV map (the snow textures live in UV "
                                 "space), or Contact Mode BOX (which makes its own)")
            uvs = np.zeros((len(tris), 3, 2), np.float32)  # BOX mode does not read them
        elif not box:
            warn_uv_overlap(obj, uvs, "snow landing on one shows on all of them (unwrap without "
                            "overlaps, or use Contact Mode BOX)")
        slots = [catch_of(s.material) for s in obj.material_slots] or [catch_of(None)]
        movers = [obj]
        parts = [(pos, tris, uvs, mi)]
        local = [pos]  # each object's vertices in its own space, at the first frame
        n = len(pos)
        if settings.colliders:
            shelter = len(slots)
            slots.append((0.0, False, True))  # colliders take no snow: flakes end there
            for o in settings.colliders.all_objects:
                if o.type != "MESH" or o == obj:
                    continue
                p, t, _, _ = mesh_data.triangles(o, dg, world=False, role="Colliders")
                movers.append(o)
                local.append(p)
                parts.append((p, t + n, np.zeros((len(t), 3, 2), np.float32),
                              np.full(len(t), shelter, np.int32)))
                n += len(p)
        tris = np.concatenate([p[1] for p in parts])
        uvs = np.concatenate([p[2] for p in parts])
        mi = np.clip(np.concatenate([p[3] for p in parts]), 0, len(slots) - 1)
        mats, shapes = yield from cls._motion(context, movers, local, frames)
        first = mats[frames[0]]
        moving = any(not np.array_equal(m, first) for m in mats.values())
        inputs = {}
        if box and any(not np.array_equal(sh[0], local[0]) for sh in shapes.values()):
            warnings.warn(f"{obj.name}: Contact Mode BOX shows the snow by the boxes of the "
                          f"bake's first frame ({frames[0]}), but the shape deforms after it, "
                          "so the snow drifts from where it landed: use TRIANGLES (with a UV "
                          "map) for a deforming shape", BakeWarning)
        if shapes:  # a deforming mesh: its world vertices on every frame they change
            shape, given, last = local, {}, None
            lo, hi = np.full(3, np.inf), np.full(3, -np.inf)
            for f in range(frames[0], frames[1] + 1):
                shape = shapes.get(f, shape)
                here = np.concatenate([(p @ m[:3, :3].T + m[:3, 3]).astype(np.float32)
                                       for p, m in zip(shape, mats[f])])
                if last is None or not np.array_equal(here, last):
                    given[f] = last = here
                    lo, hi = np.minimum(lo, here.min(axis=0)), np.maximum(hi, here.max(axis=0))
            pos = given.pop(frames[0])
            inputs["frame_positions"] = given
            reach = np.array([lo, hi])
        elif moving:  # rest positions in each object's own space, moved every frame
            pos = np.concatenate([p[0] for p in parts])
            inputs.update(transforms=mats, part_vertices=[len(p[0]) for p in parts])
            boxes = [(k, _corners(p[0])) for k, p in enumerate(parts) if len(p[0])]
            reach = np.concatenate([c @ m[k][:3, :3].T + m[k][:3, 3] for m in mats.values()
                                    for k, c in boxes])  # every part's box on every frame
        else:  # in world space once
            pos = np.concatenate([(p[0] @ m[:3, :3].T + m[:3, 3]).astype(np.float32)
                                  for p, m in zip(parts, first)])
            reach = pos
        if settings.auto_volume:
            sp["volume_min"], sp["volume_max"] = auto_volume(
                reach.min(axis=0), reach.max(axis=0), sp["wind"], sp["fall_speed"])
            most = cls.core_class().groups()["snow"].by_name["flake_count"].max
            sp["flake_count"] = _flake_count(obj, settings.flake_density, sp["volume_min"],
                                             sp["volume_max"], int(most))
        sp["time_step"], substeps = cls.substeps(scene, sp["time_step"])
        inputs.update(positions=pos, triangles=tris, uvs=uvs, material_index=mi,
                      materials=slots, substeps=substeps, flakes=settings.write_flakes)
        return params, inputs

    @staticmethod
    def _motion(context, movers, local, frames):
        """({frame: (P, 4, 4) world matrices}, {frame: [(V_k, 3) own-space vertices per
        object]} on the frames where a shape differs from the frame before, or {} when none
        does) over the bake's frames: the objects (and colliders) may move and deform. The
        scene is stepped through the frames only when something may change. A shape whose
        faces change (a Remesh under an armature) cannot carry its snow from frame to frame:
        it is taken at the first frame, with a warning."""
        deform = any(_may_deform(o) for o in movers)
        state = {"faces": None, "last": list(local), "broken": not deform}

        def sample(f=None):
            mats = np.array([np.array(o.matrix_world, np.float64) for o in movers])
            if state["broken"]:
                return mats, None
            dg = evaluated_depsgraph(context)
            shapes = [mesh_data.shape(o, dg, role=None if k == 0 else "Colliders")
                      for k, o in enumerate(movers)]
            faces = state["faces"] = state["faces"] or [loops for _, loops in shapes]
            for o, (p, loops), p0, loops0 in zip(movers, shapes, local, faces):
                if p.shape != p0.shape or not np.array_equal(loops, loops0):
                    warnings.warn(f"{o.name}: its mesh has {len(p)} vertices in {len(loops)} "
                                  f"face corners at frame {f}, {len(p0)} in {len(loops0)} at "
                                  f"frame {frames[0]}: snow cannot follow faces that change, "
                                  f"so its shape is taken at frame {frames[0]} (moved with the "
                                  "object, not deformed)", BakeWarning)
                    state["broken"] = True
                    return mats, None
            here = [p for p, _ in shapes]
            if all(np.array_equal(p, q) for p, q in zip(here, state["last"])):
                return mats, None
            state["last"] = here
            return mats, here  # kept only where it differs from the frame before
        if not deform and not any(animation.may_move(o) for o in movers):
            here = sample()[0]  # nothing animates: no need to step the scene through the range
            return {f: here for f in range(frames[0], frames[1] + 1)}, {}
        got = yield from animation.per_frame(context.scene, frames[0], frames[1], sample)
        if state["broken"]:
            return {f: m for f, (m, _) in got.items()}, {}
        return {f: m for f, (m, _) in got.items()}, {f: s for f, (_, s) in got.items()
                                                     if s is not None}

    @classmethod
    def substeps(cls, scene, time_step):
        """(substep length, substeps per frame): a frame advances exactly 1/fps of scene time,
        in as many substeps as come nearest the Time Step, each shortened or lengthened a
        little to add up to the frame (and kept within the parameter's range)."""
        frame_time = scene.render.fps_base / scene.render.fps
        spec = cls.core_class().groups()["snow"].by_name["time_step"]
        lo = max(1, math.ceil(frame_time / spec.max))
        hi = max(lo, math.floor(frame_time / spec.min))
        n = min(max(int(round(frame_time / time_step)), lo), hi)
        return frame_time / n, n

    # --- wiring -------------------------------------------------------------------------
    BOX_ATTR = "HBK_SnowBox"  # BOX mode: atlas coordinates per face corner (x, y; z = 0)
    BOX_MODIFIER = "HBK Snow Box"

    @classmethod
    def _box_projection(cls, context, obj, snow, slots, matrix):
        """The paper's projection back onto the model (§3.3.2) for BOX mode: each face takes
        the tile of its part's box that faces its normal's dominant axis, in the atlas layout
        of hbk_snow.h (a block per material slot, six tiles per block). A Geometry Nodes
        modifier, last in the stack, stores the atlas coordinates as the face corner attribute
        BOX_ATTR on the evaluated mesh, so faces that modifiers make (Mirror, Array) take
        their own tile where they are, as the simulation saw them. The boxes are measured
        as the bake did, on the evaluated mesh with the world ``matrix`` (of the bake's first
        frame); normals turn by its inverse transpose (with a non-uniform scale, the matrix
        itself tilts them)."""
        m = np.asarray(matrix, np.float64)
        pos, tris, _, mi = mesh_data.triangles(obj, evaluated_depsgraph(context),
                                               world=False)
        world = pos @ m[:3, :3].T + m[:3, 3]
        mi = np.clip(mi, 0, slots - 1)  # as prepare clips them
        lo, hi = np.zeros((slots, 3)), np.ones((slots, 3))
        for b in range(slots):
            vs = tris[mi == b].ravel()
            if len(vs):
                lo[b], hi[b] = world[vs].min(axis=0), world[vs].max(axis=0)
        inv_size = 1.0 / np.maximum(hi - lo, 1e-6)  # hbk_snow's floor for a flat part
        try:
            normal_matrix = np.linalg.inv(m[:3, :3]).T
        except np.linalg.LinAlgError:  # a zero scale: flat, the pseudo-inverse still orients
            normal_matrix = np.linalg.pinv(m[:3, :3]).T
        w, h = snow.texture_width, snow.texture_height
        name = f"HBK_{obj.name}_SnowBox"
        group = bpy.data.node_groups.get(name) or bpy.data.node_groups.new(
            name, "GeometryNodeTree")
        _box_nodes(group, cls.BOX_ATTR, m, normal_matrix, lo, inv_size, (w // 3) / w,
                   (h // 2) / h)
        mod = cls._box_modifier(obj)  # an earlier bake's (it moves no vertex)
        if mod is not None and obj.modifiers[-1] != mod:  # after modifiers added since
            obj.modifiers.remove(mod)
            mod = None
        if mod is None:
            mod = obj.modifiers.new(cls.BOX_MODIFIER, "NODES")
        old, mod.node_group = mod.node_group, group
        if old is not None and old != group and old.users == 0:  # named after an old name
            bpy.data.node_groups.remove(old)
        return cls.BOX_ATTR

    @classmethod
    def _box_modifier(cls, obj):
        """BOX mode's modifier, by its name, else (renamed by the artist) by its node group:
        a re-bake would add a second, and Free leave the first."""
        return obj.modifiers.get(cls.BOX_MODIFIER) or next((
            m for m in obj.modifiers if m.type == "NODES" and m.node_group is not None and
            m.node_group.name.startswith("HBK_") and m.node_group.name.endswith("_SnowBox")),
            None)

    @classmethod
    def _remove_box(cls, obj):
        """Takes out BOX mode's modifier and node group (and the UV map earlier versions
        made)."""
        mod = cls._box_modifier(obj)
        if mod is not None:
            group = mod.node_group
            obj.modifiers.remove(mod)
            if group is not None and group.users == 0:
                bpy.data.node_groups.remove(group)
        if obj.type == "MESH" and cls.BOX_ATTR in obj.data.uv_layers:
            obj.data.uv_layers.remove(obj.data.uv_layers[cls.BOX_ATTR])

    @classmethod
    def apply(cls, context, obj, settings, folder, manifest):
        frames = sorted(int(f) for f in manifest["frames"])
        uv = obj.data.uv_layers.active.name if obj.data.uv_layers.active else ""
        box = _is_box(manifest["params"]["snow"]["contact_mode"])
        if box:  # the atlas, not the UVs
            # As many blocks as prepare gave slots: at least one, and the colliders' own.
            slots = max(len(obj.material_slots), 1) + (1 if settings.colliders else 0)
            # The boxes as the bake measured them: the scene is on its first frame here.
            cls._box_projection(context, obj, settings.snow, slots,
                                np.array(obj.matrix_world, np.float64))
        else:
            cls._remove_box(obj)  # an earlier BOX bake's
        if not obj.material_slots or obj.material_slots[0].material is None:
            # Snow needs a material to be mixed into: a new one (Free Bake takes it away).
            # Its nodes go on below, in the object's own copy: slots lagging the mesh's are
            # filled from it, and the mesh's material may be another object's too.
            materials.ensure_material(obj, cls.made_material_name(obj.name), nodes=False)
        for index in range(len(obj.material_slots)):
            mat = obj.material_slots[index].material
            if mat is None or mat.hydrobake_snow.melts or mat.hydrobake_snow.sheds:
                continue
            mat = materials.own(obj, index, _unwire)
            materials.use_nodes(mat)  # Free Bake turns them off again
            tree = mat.node_tree
            out = next((n for n in tree.nodes if n.type == "OUTPUT_MATERIAL" and
                        n.is_active_output), None)
            if out is None or not out.inputs["Surface"].is_linked:
                continue
            x, y = out.location
            if box:
                uvn = materials.add_node(tree, "ShaderNodeAttribute", "snow.uv",
                                         (x - 900, y - 300))
                uvn.attribute_type, uvn.attribute_name = "GEOMETRY", cls.BOX_ATTR
                uv_out = uvn.outputs["Vector"]
            else:
                uvn = materials.add_node(tree, "ShaderNodeUVMap", "snow.uv", (x - 900, y - 300))
                uvn.uv_map = uv
                uv_out = uvn.outputs["UV"]
            cov = materials.add_node(tree, "ShaderNodeTexImage", "snow.coverage",
                                     (x - 700, y - 300))
            cov.image = images.load_sequence(folder, "coverage", frames[0], len(frames),
                                             name=f"HBK_{obj.name}_snow_coverage")
            images.configure_user(cov.image_user, frames[0], len(frames))
            tree.links.new(uv_out, cov.inputs["Vector"])
            white = materials.add_node(tree, "ShaderNodeBsdfPrincipled", "snow.bsdf",
                                       (x - 450, y - 450))
            white.inputs["Base Color"].default_value = (0.92, 0.94, 0.97, 1.0)
            white.inputs["Roughness"].default_value = 0.75
            white.inputs["Subsurface"].default_value = 0.2
            white.inputs["Subsurface Color"].default_value = (0.8, 0.9, 1.0, 1.0)
            mix = materials.add_node(tree, "ShaderNodeMixShader", "snow.mix", (x - 200, y))
            surface = out.inputs["Surface"].links[0].from_socket
            # A re-bake (or Resume) finds its own mix there. Blender hands out a new wrapper
            # for a node at every access: compare with ==, never with `is`.
            if surface.node != mix:
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
                tree.links.new(uv_out, dep.inputs["Vector"])
                disp = materials.add_node(tree, "ShaderNodeDisplacement", "snow.displacement",
                                          (x - 300, y - 600))
                disp.space = "WORLD"  # the depth is in metres, whatever the object's scale
                disp.inputs["Midlevel"].default_value = 0.0
                disp.inputs["Scale"].default_value = 1.0
                tree.links.new(dep.outputs["Color"], disp.inputs["Height"])
                tree.links.new(disp.outputs["Displacement"], out.inputs["Displacement"])
            else:  # turned off since an earlier bake, or a stale bake's (a deleted object's
                # made material this object took: every flag + --scene --external
                # --relations 727): the surface no longer moves
                for role in ("snow.depth", "snow.displacement"):
                    materials.remove_tagged(tree, role)

        if "flakes" in manifest.get("streams", []):
            white = bpy.data.materials.get("HBK Snow Flake") or _flake_material()
            old = helper_objects.find("snow", obj.name, "flakes", "MESH")  # renamed, maybe
            flakes = points.attach(old.name if old else f"HBK_{obj.name}_flakes", folder,
                                   "flakes", settings.snow.flake_radius * 2.0,
                                   collection=obj.users_collection[0] if obj.users_collection
                                   else None, material=white)
            helper_objects.tag(flakes, "snow", obj.name, "flakes")

    @classmethod
    def let_go(cls, context, obj, settings, keep):
        cls._remove_box(obj)
        for mat in cls.slot_materials(obj, settings) - set(keep):
            if mat.node_tree:
                _unwire(mat.node_tree)
            materials.give_back(obj, mat, "snow.")
        materials.restore(obj, "snow.")

    @classmethod
    def remove(cls, context, obj, settings):
        _detach_flakes(cls.baked_name(obj, settings))
        cls._remove_box(obj)
        # The bake's wiring wherever it is: in the object's slots, and in materials taken
        # out of them since (or a shared one a re-bake made a copy of), known by its images.
        name = cls.baked_name(obj, settings)
        mats = cls.slot_materials(obj, settings)
        mats |= set(materials.holding("snow.", {f"HBK_{name}_{s}" for s in STREAMS}))
        for mat in mats:
            if mat.node_tree:
                _unwire(mat.node_tree)
            materials.give_back(obj, mat, "snow.")  # nodes switched on, a material made
        materials.restore(obj, "snow.", made=cls.made_material_name(name))
        for stream in STREAMS:
            images.remove(f"HBK_{name}_{stream}")

    @classmethod
    def wired_names(cls):
        names = cls.shown_in()
        for o in bpy.data.objects:  # the flakes
            if o.name.startswith("HBK_") and o.name.endswith("_flakes") and \
                    str(o.get(frame_meshes.PROP, "")).startswith("points|"):
                names.add(o.name[len("HBK_"):-len("_flakes")])
        return names | helper_objects.owners("snow", ("flakes",))

    @classmethod
    def forget(cls, name):
        _detach_flakes(name)
        shown = {f"HBK_{name}_{stream}" for stream in STREAMS}
        materials.forget(name, "snow.", shown, _unwire)
        for image in shown:
            images.remove(image)

    @classmethod
    def draw_settings(cls, layout, settings):
        col = layout.column()
        for name in ("colliders", "auto_volume", "flake_density", "use_displacement",
                     "write_flakes"):
            row = col.row()
            row.active = name != "flake_density" or settings.auto_volume
            row.prop(settings, name)
            if name == "flake_density" and settings.auto_volume:
                count, size = estimate(settings.id_data, settings)
                col.label(text=f"About {count:,} flakes in {size[0]:.1f} x {size[1]:.1f} x "
                               f"{size[2]:.1f} m", icon="INFO")
        super().draw_settings(layout, settings)

    @classmethod
    def derived(cls, settings):
        if not settings.auto_volume:
            return {}
        off = "; set auto_volume false to set it"
        return {"snow.flake_count": "Flake Density (flake_density) sets it while Auto Volume "
                                    "is on" + off,
                "snow.volume_min": "Auto Volume fits it around the object" + off,
                "snow.volume_max": "Auto Volume fits it around the object" + off}


