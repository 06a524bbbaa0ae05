"""A randomized, seeded "monkey" test of the real addon in ``blender -b``: random sequences of
what an artist does to small scenes of the four effects (Bake, Free Bake, Cancel + Resume,
re-bakes with a changed setting, Shift+D copies, renames, deletes, material slots (moved and
tidied with --moves), Join, Make Single User and Link Materials (--relations), File >
External Data's absolute and relative paths, Pack and Unpack, Purge Unused Data and another
Cache Folder (--external), the scene's frame rate and range (--scene), the fluid's source
(a particle emitter and a Mantaflow liquid, --sources), the fluid's obstacles, one keyed
(--obstacles, with a pool's sinking floor), any object renamed (a pool's
ground, a bake's projector, flakes or modifiers: --renames), modifiers, visibility,
save and reopen, undo, the command line in-process and in a subprocess), with the invariants
checked after every step:

* no Python exception but the addon's clear refusals (ValueError / RuntimeError naming an
  object or a setting), no traceback printed;
* every object whose settings say is_baked has a folder with a valid, complete or resumable
  manifest whose listed files (frames and checkpoints) exist and match their SHA-256, and
  nothing else but the manifest in it (no temporaries, no lock, no unlisted frame);
* every image and volume of a bake that something uses reads a file that exists (a Save As
  with Remap Relative off left them relative to the folder the file was in), and one packed
  holds what its file holds (a re-bake kept the old bake's packed copy);
* no bake folder on disk that no object records, unless it was freed on purpose (a
  superseded folder of a renamed object waits for the save; a deleted object's stays);
* whenever nothing is baked: every object and material is as it was before its first bake
  (material per slot, the material's node count, links and shader values, modifiers,
  visibility, Hydrobake's custom properties), no node tagged by Hydrobake, no HBK_* object
  (nor one renamed from HBK_*), material, image or modifier is left;
* after a pool's bake its floor nodes are in its ground's materials only;
* at the end the scene renders a frame in Cycles (32 x 32 px, 1 sample, no denoiser).

    blender -b --factory-startup --python monkey.py -- TMPDIR SEED [--steps N]
        [--effects caustics,rain,snow,fluid] [--replay FILE.json] [--delete-baked] [--more]
        [--elsewhere] [--moves] [--relations] [--external] [--scene] [--sources] [--obstacles]
        [--renames] [--no-subprocess]
        [--no-render] [--known] [--trace]

--known goes on past the violations already reported (KNOWN below), to find others; --trace
prints every object's state after each step. Prints ``MONKEY OK seed=S steps=N`` on success, else ``MONKEY FAIL seed=S step=K kind=...``
with the violation; the action log (replayable with --replay) is written to
TMPDIR/actions.json either way."""
import argparse
import contextlib
import io
import json
import math
import os
import random
import re
import subprocess
import sys
import traceback

import bpy

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import in_blender  # noqa: E402

in_blender.enable()
from hydrobake.blender import cli, jobs, paths  # noqa: E402
from hydrobake.blender import effects as hb_effects  # noqa: E402
from hydrobake.core import errors  # noqa: E402
from hydrobake.core.bake.cache import BakeCache, file_checksum  # noqa: E402

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", "..", ".."))
BATCH = os.path.join(ROOT, "build", "hydrobake-batch")
EFFECTS = ("caustics", "rain", "snow", "fluid")
SETTINGS_KEYS = {f"hydrobake_{e}" for e in EFFECTS} | {"hydrobake_fluid_paint"}
REFUSALS = (ValueError, RuntimeError, KeyError, errors.HydrobakeError)


# Violations already reported (--known masks them so that a run goes on to find others):
# kind -> predicate on the offending item (a name, or the violation's detail).
# None now: the last one listed (a Shift+D copy that holds the original's record re-baked
# after the original was freed and left the original's folder) is freed at the next save as
# a renamed object's old bake is (tests/blender/scripts/shared_records.py).
KNOWN = {}


class Violation(Exception):
    def __init__(self, kind, detail):
        super().__init__(f"{kind}: {detail}")
        self.kind, self.detail = kind, detail


# --- output capture: a traceback printed by the addon is a bug even if nothing raises -------
class Tee(io.TextIOBase):
    def __init__(self, real):
        self.real, self.buf = real, io.StringIO()

    def write(self, s):
        self.real.write(s)
        self.buf.write(s)
        return len(s)

    def flush(self):
        self.real.flush()


@contextlib.contextmanager
def captured():
    out, err = Tee(sys.stdout), Tee(sys.stderr)
    old = sys.stdout, sys.stderr
    sys.stdout, sys.stderr = out, err
    try:
        yield out.buf, err.buf
    finally:
        sys.stdout, sys.stderr = old


# --- the scene ------------------------------------------------------------------------------
def uv_plane(name, size, loc):
    obj = in_blender.new_plane(name)
    obj.scale, obj.location = (size, size, 1.0), loc
    uv = obj.data.uv_layers.new(name="UVMap")
    for loop, c in zip(uv.data, ((0, 0), (1, 0), (1, 1), (0, 1))):
        loop.uv = c
    return obj


def uv_cube(name, size, loc):
    import bmesh
    obj = in_blender.new_plane(name)
    bm = bmesh.new()
    bmesh.ops.create_cube(bm, size=1.0, calc_uvs=True)
    bm.to_mesh(obj.data)
    bm.free()
    if not obj.data.uv_layers:
        obj.data.uv_layers.new(name="UVMap")
    obj.scale, obj.location = (size,) * 3, loc
    return obj


def user_material(name, nodes=True, transmission=None):
    mat = bpy.data.materials.new(name)
    mat.use_nodes = nodes
    if nodes and transmission is not None:
        bsdf = next(n for n in mat.node_tree.nodes if n.type == "BSDF_PRINCIPLED")
        bsdf.inputs["Transmission"].default_value = transmission
    return mat


def setup_caustics(obj, ground):
    s = obj.hydrobake_caustics
    s.enabled, s.ground_object = True, ground
    s.use_scene_range, s.frame_start, s.frame_end = False, 1, 3
    s.water.width, s.map_resolution = 16, 32


def setup_rain(obj):
    s = obj.hydrobake_rain
    s.enabled, s.rain.cell_size = True, 0.05
    s.use_scene_range, s.frame_start, s.frame_end = False, 1, 3


def setup_snow(obj, rng_or_tex):
    in_blender.snow(obj, (1, 3), 40.0, rng_or_tex)


def cone(name, location):
    """A closed cone 0.16 m across and 0.15 m tall (a mesh obstacle of neither box nor ball
    shape)."""
    import bmesh
    obj = in_blender.new_plane(name)
    bm = bmesh.new()
    bmesh.ops.create_cone(bm, cap_ends=True, segments=8, radius1=0.08, radius2=0.0, depth=0.15)
    bm.to_mesh(obj.data)
    bm.free()
    obj.location = location
    return obj


def blobs(name, location):
    """Two metaballs of one family, ``name`` and ``name``.001, 0.1 m apart; the member drifts
    0.1 m along x over frames 1-3 (Blender melts the family into one surface, held by the
    basis: the member is that surface, and it changes shape). Returns the member; a rename
    takes it out of the family."""
    objs = []
    for k in range(2):
        mb = bpy.data.metaballs.new(f"{name}{'.001' if k else ''}")
        mb.elements.new().radius = 0.06
        obj = bpy.data.objects.new(mb.name, mb)
        bpy.context.scene.collection.objects.link(obj)
        obj.location = (location[0] + 0.1 * k, location[1], location[2])
        objs.append(obj)
    for frame, dx in ((1, 0.1), (3, 0.2)):
        objs[1].location.x = location[0] + dx
        objs[1].keyframe_insert("location", index=0, frame=frame)
    return objs[1]


def hoop(name, location):
    """A bevelled circle 0.2 m across whose tube swells from 2 to 4 cm over frames 1-3 (a
    curve obstacle whose shape changes: a field every frame)."""
    curve = bpy.data.curves.new(name, "CURVE")
    curve.dimensions = "3D"
    spline = curve.splines.new("POLY")
    spline.points.add(11)
    for i, p in enumerate(spline.points):
        a = 2.0 * math.pi * i / 12
        p.co = (0.1 * math.cos(a), 0.1 * math.sin(a), 0.0, 1.0)
    spline.use_cyclic_u = True
    obj = bpy.data.objects.new(name, curve)
    bpy.context.scene.collection.objects.link(obj)
    obj.location = location
    for frame, depth in ((1, 0.02), (3, 0.04)):
        curve.bevel_depth = depth
        curve.keyframe_insert("bevel_depth", frame=frame)
    return obj


def build_scene(seed, effects, tmp, sources=False, obstacles=False):
    """The seed's small scene: the effects' objects, a camera and a sun. Deterministic.
    ``sources`` (--sources) adds an emitter of particles in the fluid domain, the domain's
    source (PARTICLES) half the time, and a baked Mantaflow liquid "Tank" (its cache in
    //manta/), textured by its own velocity (VELOCITY_GRID) half the time. ``obstacles``
    (--obstacles) gives the fluid an Obstacles collection of a still, tilted rock, a cone (a
    mesh), a curve hoop that swells, and a paddle keyed to move into the water turning
    (followed frame by frame), and a keyed tap as its Inflow from frame 2 (a third of the
    seeds with no Fill: the domain starts dry; half with the tap turning and its velocity
    turning with it, Local Velocity; half with a drain in the floor's far end as its
    Outflow)."""
    rng = random.Random(seed * 7919 + 1)
    for coll in (bpy.data.objects, bpy.data.meshes, bpy.data.materials, bpy.data.cameras,
                 bpy.data.lights):
        for block in list(coll):
            coll.remove(block)
    blend = os.path.join(tmp, "monkey.blend")
    bpy.ops.wm.save_as_mainfile(filepath=blend)
    scene = bpy.context.scene
    scene.frame_start, scene.frame_end = 1, 3
    cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    scene.collection.objects.link(cam)
    cam.location, cam.rotation_euler = (0.0, -9.0, 7.0), (0.9, 0.0, 0.0)
    scene.camera = cam
    sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
    scene.collection.objects.link(sun)
    sun.rotation_euler = (0.3, 0.2, 0.0)
    if "caustics" in effects:
        ground = uv_plane("Ground", 1.5, (0, 0, -0.4))
        ground.data.materials.append(user_material("GroundMat"))
        water = in_blender.new_plane("Water")
        if rng.random() < 0.5:
            water.data.materials.append(user_material("WaterMat", nodes=rng.random() < 0.7))
        setup_caustics(water, ground)
        if obstacles:  # a floor that sinks, followed frame by frame
            for frame, z in ((1, -0.4), (3, -0.5)):
                ground.location.z = z
                ground.keyframe_insert("location", index=2, frame=frame)
    if "rain" in effects:
        glass = uv_plane("Glass", 0.5, (3.0, 0.0, 1.0))
        r = rng.random()
        if r < 0.5:
            glass.data.materials.append(user_material("GlassMat", transmission=1.0))
        elif r < 0.75:
            glass.data.materials.append(user_material("GlassMat", transmission=0.0))
            glass.data.materials.append(user_material("FritMat"))
        setup_rain(glass)
    if "snow" in effects:
        tex = rng.choice((16, 24, 32))
        snowy = uv_cube("Snowy", 0.5, (-3.0, 0.0, 0.5)) if rng.random() < 0.5 else \
            uv_plane("Snowy", 0.5, (-3.0, 0.0, 0.0))
        if rng.random() < 0.6:
            snowy.data.materials.append(user_material("SnowyMat", nodes=rng.random() < 0.8))
        setup_snow(snowy, tex)
    if "fluid" in effects:
        domain, fill, s = in_blender.dam_break((24, 12, 12), textures=2, frames=(1, 2))
        for o in (domain, fill):
            o.location.y += 3.0
        if obstacles:
            # the water poured as a ball (the Fill by its shape), not the column's box
            bpy.ops.mesh.primitive_uv_sphere_add(radius=0.12, location=(0.15, 3.25, 0.25))
            s.fill_object = bpy.context.active_object
            s.fill_object.name = "Drop"
            rocks = bpy.data.collections.new("Rocks")
            bpy.context.scene.collection.children.link(rocks)
            rock = in_blender.new_box("Rock", (0.1, 0.1, 0.1), (0.8, 3.1, 0.05))
            rock.rotation_euler = (0.3, 0.2, 0.5)  # a turned box
            rocks.objects.link(rock)
            paddle = in_blender.new_box("Paddle", (0.05, 0.3, 0.3), (0.9, 3.3, 0.15))
            rocks.objects.link(paddle)
            rocks.objects.link(cone("Cone", (0.6, 3.35, 0.08)))  # a mesh: its shape
            rocks.objects.link(hoop("Hoop", (0.3, 3.2, 0.12)))  # a curve that swells
            rocks.objects.link(blobs("Blob", (0.2, 3.45, 0.08)))  # a metaball family's member
            for frame, x, turn in ((1, 0.9, 0.0), (3, 0.5, 0.8)):
                paddle.location.x, paddle.rotation_euler.z = x, turn
                paddle.keyframe_insert("location", index=0, frame=frame)
                paddle.keyframe_insert("rotation_euler", index=2, frame=frame)
            s.obstacles = rocks
            # a tap keyed to move, pouring from frame 2 (the Inflow, followed)
            tap = in_blender.new_box("Tap", (0.06, 0.06, 0.06), (0.4, 3.25, 0.4))
            for frame, x in ((1, 0.4), (3, 0.6)):
                tap.location.x = x
                tap.keyframe_insert("location", index=0, frame=frame)
            if random.Random(seed * 47 + 19).random() < 0.3:  # a planar tap (its own draw)
                bpy.ops.mesh.primitive_plane_add(size=0.1, location=(0.4, 3.25, 0.4))
                tap = bpy.context.active_object
                tap.name = "Sheet"
                for frame, x in ((1, 0.4), (3, 0.6)):
                    tap.location.x = x
                    tap.keyframe_insert("location", index=0, frame=frame)
            s.inflow_object, s.inflow_velocity, s.inflow_start = tap, (0.5, 0.0, -1.0), 2
            if random.Random(seed * 59 + 29).random() < 0.3:  # more taps (its own draw)
                more = bpy.data.collections.new("Taps")
                bpy.context.scene.collection.children.link(more)
                more.objects.link(in_blender.new_box("Tap2", (0.05, 0.05, 0.05),
                                                     (0.7, 3.35, 0.35)))
                more.objects.link(tap)  # (also the Inflow: it pours once)
                s.inflow_collection = more
            if random.Random(seed * 53 + 23).random() < 0.3:  # a tap turned up (keyed)
                s.keyframe_insert("inflow_velocity", frame=1)
                s.inflow_velocity = (0.0, 0.0, -2.0)
                s.keyframe_insert("inflow_velocity", frame=3)
            if random.Random(seed * 31 + 7).random() < 0.3:  # (its own draw: the rest stays)
                s.fill_object = None  # the domain starts dry, the tap its only water
            if random.Random(seed * 43 + 17).random() < 0.3:  # a sprinkler (its own draw)
                s.inflow_normal = 0.8
            if random.Random(seed * 41 + 13).random() < 0.5:  # a nozzle that turns
                s.inflow_local = True
                tap.keyframe_insert("rotation_euler", index=1, frame=1)
                tap.rotation_euler.y = 0.5
                tap.keyframe_insert("rotation_euler", index=1, frame=3)
            if random.Random(seed * 37 + 11).random() < 0.5:  # a drain in the floor's far end
                s.outflow_object = in_blender.new_box("Drain", (0.2, 0.5, 0.06),
                                                      (0.9, 3.25, 0.0))
                if random.Random(seed * 43 + 17).random() < 0.5:  # a plug pulled at frame 2
                    s.outflow_start = 2
            if random.Random(seed * 61 + 31).random() < 0.3:  # more drains (its own draw)
                sumps = bpy.data.collections.new("Sumps")
                bpy.context.scene.collection.children.link(sumps)
                sumps.objects.link(in_blender.new_box("Sump", (0.15, 0.15, 0.05),
                                                      (0.5, 3.4, 0.0)))
                s.outflow_collection = sumps
        if sources:  # its own generator: the fixed seeds' scenes stay as they were
            emitter = in_blender.new_box("Emitter", (0.3, 0.3, 0.05), (0.5, 3.25, 0.4))
            ps = emitter.modifiers.new("Drops", "PARTICLE_SYSTEM").particle_system.settings
            ps.count, ps.frame_start, ps.frame_end, ps.lifetime = 300, 1, 1, 100
            ps.emit_from = "VOLUME"
            rng4 = random.Random(seed * 104729 + 5)
            if rng4.random() < 0.5:
                s.fluid.source, s.particle_object = "PARTICLES", emitter
            bpy.ops.wm.save_mainfile()  # (//manta/ is the saved file's folder)
            tank, _d, _flow = in_blender.liquid((0.0, 8.0, 1.0), 16, "//manta/", 0.4,
                                                (0.0, 8.0, 1.3))
            in_blender.bake_liquid(tank)
            if rng4.random() < 0.5:
                t = tank.hydrobake_fluid
                t.enabled, t.fluid.source, t.fluid.textures = True, "VELOCITY_GRID", 2
                t.fluid.resolution = (12, 12, 12)
                t.use_scene_range, t.frame_start, t.frame_end = False, 1, 2
    bpy.ops.wm.save_mainfile()
    return blend


def paths_inside(path, roots):
    """Whether the absolute ``path`` is in one of the folders ``roots``."""
    real = os.path.realpath(path)
    return any(real.startswith(os.path.join(os.path.realpath(r), "")) for r in roots)


# --- what the scene holds now --------------------------------------------------------------
# The helper objects bakes add (a projector, a grid Empty, flakes, a fluid's surface) that
# --renames renamed: their name now -> the name the addon gave them (HBK_<bake>_<role>). The
# new names (Helper<n>) are the monkey's alone, so an undone rename leaves a name no other
# object takes.
RENAMED = {}


def made_name(name):
    return RENAMED.get(name, name)


def scene_objects():
    return sorted((o for o in bpy.data.objects if o.type == "MESH" and
                   not made_name(o.name).startswith("HBK")), key=lambda o: o.name)


def targets(effect=None):
    """(object name, effect) pairs with the effect enabled."""
    out = []
    for o in scene_objects():
        for e in EFFECTS:
            if (effect is None or e == effect) and getattr(o, f"hydrobake_{e}").enabled:
                out.append((o.name, e))
    return out


select_alone = in_blender.select_alone


def is_liquid_domain(obj):
    return any(m.type == "FLUID" and m.fluid_type == "DOMAIN" for m in obj.modifiers)


MESH_ASPECTS = ("slots", "mesh", "behind")  # what Join, Link Materials, ... change


def baked_pairs():
    return [(o.name, e) for o in bpy.data.objects for e in EFFECTS
            if getattr(o, f"hydrobake_{e}").is_baked]


def _round(v):
    if isinstance(v, float):
        return round(v, 4)
    try:
        return tuple(round(float(x), 4) for x in v)
    except TypeError:
        return v


def mat_state(m):
    # The mark by which a bake's copies find their shared material again after a rename
    # (materials.follow_renames) is the addon's bookkeeping, not the artist's state: it stays
    # while a copy records it (a deleted object's, until Remove Deleted Objects' Bakes), and
    # one no copy records any more goes at the next Bake, Free or opening of the file (a copy
    # gone at a reopen or a purge: every flag + --scene --external 936, 940). What it is for
    # is checked by renamed_shared.py.
    st = {"use_nodes": m.use_nodes, "eevee": (m.blend_method, m.use_screen_refraction),
          "props": sorted(k for k in m.keys()
                          if k not in ("hydrobake_snow", "hydrobake_shared_as"))}
    if m.node_tree and m.use_nodes:  # nodes switched off: what they hold does not show
        tree = m.node_tree
        st["nodes"] = sorted(n.name for n in tree.nodes)
        st["links"] = sorted(f"{l.from_node.name}.{l.from_socket.identifier}>"
                             f"{l.to_node.name}.{l.to_socket.identifier}" for l in tree.links)
        vals = {}
        for n in tree.nodes:
            if n.type in ("BSDF_PRINCIPLED", "BSDF_GLASS"):
                for k in ("Transmission", "Roughness", "IOR", "Base Color"):
                    if k in n.inputs:
                        vals[f"{n.name}.{k}"] = _round(n.inputs[k].default_value)
        st["values"] = vals
    return st


def _layer_collection(lc, coll):
    if lc.collection == coll:
        return lc
    return next((f for f in (_layer_collection(c, coll) for c in lc.children) if f), None)


DROPPED = object()  # Monkey.stands_for: a slot that goes with a deleted object's bake
EMPTIED = object()  # ... and the artist's empty slot it filled, which stays (7206)


def _gone_with(made):
    """What a slot holding a deleted object's made material (its MADE value ``made``) becomes
    once that bake is removed: the artist's slot it filled stays, empty; one appended goes."""
    return EMPTIED if made == "slot" else DROPPED


def wired(mat):
    """Whether a bake's nodes are in the material (Hydrobake's tag)."""
    return bool(mat.node_tree) and any(n.get("hydrobake") for n in mat.node_tree.nodes)


def slot_name(mat):
    """A material's name, an object's own copy of a shared one (own()) named for what it
    stands for: its name follows the object's renames at its re-bakes (seed 533), not at
    others (244)."""
    if mat is None:
        return None
    if "hydrobake_copy_of" in mat:
        return f"{mat['hydrobake_copy_of']} (a copy)"
    return mat.name


def slots_of(o):
    """(link, material) of the object's slots, as the file shows them once saved and opened.
    A slot added to or removed from a mesh through one of its objects (Alt+D copies) shows on
    the others only then: Blender 3.4 resizes the mesh and that object, not the others."""
    have = [(s.link, s.material) for s in o.material_slots]
    if o.type == "MESH":
        have = have[:len(o.data.materials)]
        have += [("DATA", m) for m in o.data.materials[len(have):]]
    return have


def behind_mesh(o):
    """The artist's own materials an object keeps behind its mesh's (a slot's Link set back
    to Data): (slot, name). A bake's copy went over one and its Free gave none back."""
    if o.type != "MESH":
        return []
    out = []
    for i, s in enumerate(o.material_slots[:len(o.data.materials)]):
        if s.link == "DATA":
            s.link = "OBJECT"
            m = s.material
            s.link = "DATA"
            if m is not None and "hydrobake_copy_of" not in m and "hydrobake_made" not in m:
                out.append((i, m.name))
    return out


def _foreign_copy(o, m):
    """Whether ``m`` is a copy own() made for another object still in the file (one renamed
    since is the copy's own object: COPY_FOR names no object then)."""
    made_for = m.get("hydrobake_copy_for") if m is not None else None
    return made_for is not None and made_for != o.name and made_for in bpy.data.objects


def _slots(o, name_of, foreign_as_own):
    # A DROPPED slot goes only where no other slot follows it; before one it stays, empty:
    # the artist's slots keep their indices, which the faces use (monkey --more 1357).
    # A clean copy standing for the mesh's material (name_of gives that one's name) stands
    # on the object's own slot of a shared mesh: the slot's Link is the mesh's then (1738).
    # Another object's copy in a slot (put there by the artist) stays as it is, unless a
    # bake of this object copies it again as its own, which Free puts back (foreign_as_own).
    # That bake's copy keeps the other (or a deleted) object's record of its own slot only
    # where the mesh shows the shared material in that slot (a Shift+D copy of a baked
    # object): Free switches the Link back there, and elsewhere puts the shared one in the
    # slot as it is (every flag + --scene --external 950).
    def named(m):
        n = name_of(m)
        return slot_name(m) if not foreign_as_own and _foreign_copy(o, m) and \
            n == m.get("hydrobake_copy_of") else n
    mesh = [m.get("hydrobake_copy_of", m.name) if m is not None else None
            for m in o.data.materials] if o.type == "MESH" else []
    def link_was(i, m):
        if m is None or m.get("hydrobake_link_was") != "DATA":
            return False
        if not foreign_as_own:
            # The record holds where the mesh's slot stands for the copy's shared material,
            # as own() keeps it: Move Slot on an Alt+D copy moves the mesh's slots under this
            # object's own ones, and a re-bake's copy drops the record then (every flag +
            # --scene --external 981: the slot showed the copy, and shows one after).
            return not _foreign_copy(o, m) and (named(m) == EMPTIED or (
                i < len(mesh) and mesh[i] == m.get("hydrobake_copy_of")))
        if m.get("hydrobake_copy_for") != o.name:
            return i < len(mesh) and mesh[i] == m.get("hydrobake_copy_of")
        return True
    return [("DATA" if link_was(i, m) and named(m) in (m.get("hydrobake_copy_of"), EMPTIED)
             else link, named(m))
            for i, (link, m) in enumerate(slots_of(o))]


EMPTY_SLOT_MARK = "hydrobake_empty_slot"  # materials.EMPTY_SLOT, on a mesh


def obj_state(o, name_of=slot_name, pending=None):
    """The object's state as Free gives it back. ``slots_alt`` is the slots' other reading
    where another object's copy is in one (monkey 7262): whether this object was baked since
    decides which one Free gives back. ``pending(material)``: whether it waits for a deleted
    object's bake to be removed (Monkey.waits_for_deleted)."""
    slots = _slots(o, name_of, False)
    # The mark of a mesh's slot kept for a deleted object's made material stays with it, until
    # Remove Deleted Objects' Bakes (monkey --more --delete-baked --elsewhere 7147); so does
    # one kept while an object of the mesh shows a copy waiting for that (materials.
    # _drop_empty_slot keeps it while a copy is shown: every flag + --scene --external 922,
    # a snapshot with nothing baked taken while a clean copy waited for its shared one).
    # So does one whose slot a deleted object's made material filled again, hidden behind
    # every object's own there (every flag + --scene 2137).
    users = [u for u in bpy.data.objects if u.data == o.data] if o.type == "MESH" else []
    held = [m for u in users for _l, m in slots_of(u)] + list(o.data.materials) if users \
        else []
    mark = {EMPTY_SLOT_MARK} if any(n in (DROPPED, EMPTIED) for _l, n in slots) or (
        pending is not None and any(pending(m) for m in held)) else set()
    def tidy(slots):
        while slots and slots[-1][1] is DROPPED:
            slots.pop()
        return [(link, None if name in (DROPPED, EMPTIED) else name) for link, name in slots]
    kept = tidy(slots)
    return {
        "slots": kept,
        "slots_alt": tidy(_slots(o, name_of, True)),
        # (the object's own material behind a DROPPED slot goes with it: _drop_slot)
        "behind": [(i, n) for i, n in behind_mesh(o) if i < len(kept)],
        "mods": [(m.name, m.type, m.show_viewport, m.show_render) for m in o.modifiers],
        "vis": {"hide_render": o.hide_render, "hide_viewport": o.hide_viewport,
                "visible_shadow": o.visible_shadow, "display_type": o.display_type,
                "hidden": o.hide_get()},
        "props": sorted(k for k in o.keys() if k not in SETTINGS_KEYS),
        "mesh": {"uv": sorted(l.name for l in o.data.uv_layers),
                 "props": sorted(set(o.data.keys()) - mark)} if o.type == "MESH" else None,
    }


def stale_mark_gone(have, want):
    """Whether the mesh differs from its snapshot only by the empty-slot mark gone. The mark
    is Hydrobake's note of a slot to drop once no object shows anything there; the artist's
    own material put there since (Link Materials over the slot it was kept for) makes it
    stale, and the next Free of any object tidies it (every flag + --sources 772: taken into
    a snapshot while stale). A mark left behind is still caught; a slot wrongly kept, by
    the slots' check."""
    return have["uv"] == want["uv"] and EMPTY_SLOT_MARK not in have["props"] and \
        set(want["props"]) == set(have["props"]) | {EMPTY_SLOT_MARK}


class Monkey:
    def __init__(self, seed, tmp, effects, subprocess_ok=True, delete_baked=False):
        self.seed, self.tmp, self.effects = seed, tmp, effects
        self.rng = random.Random(seed)
        # Draws added since: their own generator, so that the fixed seeds' sequences stay.
        self.rng2 = random.Random(seed + 100003)
        self.rng3 = random.Random(seed + 200003)  # (and --external's Cache Folder changes)
        self.subprocess_ok, self.delete_baked = subprocess_ok, delete_baked
        self.log = []
        self.blend = None
        self.farm = os.path.join(tmp, "farm")
        self.abandoned = set()  # folders of baked objects deleted on purpose
        self.deleted_bakes = set()  # ... and the names their bakes were wired under
        self.removed_deleted = False  # Remove Deleted Objects' Bakes ran (at the end)
        self.used_names = set()
        self.more = False  # --more: Alt+D, slot links, collections
        self.elsewhere = False  # --elsewhere: Save As / Save Copy into other folders
        self.moves = False  # --moves: slots moved up and down, unused slots removed
        self.relations = False  # --relations: Join, Make Single User, Link Materials
        self.external = False  # --external: paths absolute / relative, pack, unpack, purge
        self.scene_ops = False  # --scene: the scene's frame rate and range
        self.sources = False  # --sources: an emitter and a liquid, the fluid's source switched
        self.obstacles = False  # --obstacles: a tilted rock and a turning, keyed paddle
        self.renames = False  # --renames: any object renamed (a pool's ground), not a target's
        self.given_hbk = set()  # HBK materials the artist gave other objects (--relations)
        self.left_behind = set()  # bake folders of the files saved elsewhere from
        self.snap_objs, self.snap_mats, self.dirty = {}, {}, set()
        self.copies = {}  # copy name -> name of the object it was copied from
        self.counter = 0
        self.undo_works = None
        self.notes = []
        self.mask_known = False
        self.trace = False
        self.had_bake = False
        self.all_copies = set()
        self.output_orphans = set()
        self.roots_seen = set()  # every cache folder a setting named (--external)
        self.known_seen = set()
        self.purged = set()  # addresses of materials Purge removed (do_purge)
        self.record = None  # main's record of the run, written before each step
        # (--external) per image and volume packed by Pack Resources: its path (as the artist's
        # Make Paths Absolute / Relative left it since) and the file it named when packed
        self.packed_from = {}

    # --- invariants -------------------------------------------------------------------------
    def known(self, kind, item):
        if self.mask_known and kind in KNOWN and KNOWN[kind](self, item):
            if (kind, str(item)) not in self.known_seen:  # said once per item
                self.known_seen.add((kind, str(item)))
                print(f"MONKEY KNOWN {kind}: {item}", flush=True)
            return True
        return False

    def check(self, where):
        if jobs.ACTIVE:
            raise Violation("active-job", f"jobs still ACTIVE after {where}: {list(jobs.ACTIVE)}")
        recorded = set()
        for o in bpy.data.objects:
            for e in EFFECTS:
                s = getattr(o, f"hydrobake_{e}", None)
                if s is None or not s.is_baked:
                    continue
                folder = s.bake_folder
                self.check_folder(o.name, e, folder)
                recorded.add(os.path.realpath(folder))
        for o in bpy.data.objects:  # every panel draws, whatever the file has become
            for e in EFFECTS:
                if not hb_effects.get(e).poll(o):
                    continue
                try:
                    in_blender.panel_calls(o, e)
                except Exception as exc:
                    raise Violation("panel", f"{o.name} {e} panel: {type(exc).__name__}: "
                                             f"{exc}") from exc
        for block in (*bpy.data.images, *bpy.data.volumes):  # (a bake's, shown: its file)
            if not (block.name.startswith("HBK") and block.filepath and block.users and
                    block.library is None):
                continue
            path = bpy.path.abspath(block.filepath)
            if block.packed_file is not None:  # (--external) it shows what it packed
                # Blender's rule for a relative path a Save As left unremapped: the path, as
                # it was when packed, now names a file of the new folder (another version of
                # the shot's bake there, or another bake's unpacked image), and the packed
                # copy is what shows (every flag + --scene --external 933, 941).
                was = self.packed_from.get((type(block).__name__, block.name))
                moved = was is not None and was[0] == block.filepath and \
                    was[1] != os.path.realpath(path)
                if os.path.exists(path) and not moved:
                    with open(path, "rb") as f:
                        if f.read() != block.packed_file.data:
                            raise Violation("stale-pack", f"{block.name} shows what it packed, "
                                                          f"not {block.filepath}")
            elif not os.path.exists(path) and (not self.external or paths_inside(
                    path, self.bake_folder_roots())):  # (else unpacked into the artist's
                raise Violation("missing-file", f"{block.name} reads {block.filepath}, "
                                                "which leads nowhere")  # folder, //textures)
        allowed = {os.path.realpath(f) for f in self.abandoned}
        # By design a bake sent to another folder on purpose (the command line's --output, all
        # under the farm folder) replaces nothing and is replaced by nothing: the bake it took
        # the record from stays, and so does it once the object bakes elsewhere again.
        allowed |= self.output_orphans
        # A file saved elsewhere leaves its old self behind, recording the bakes it had: a
        # re-bake of a renamed object in the new place replaces none of them (not beside it).
        allowed |= self.left_behind
        farm = os.path.realpath(self.farm) + os.sep
        for o in bpy.data.objects:
            for e in EFFECTS:
                s = getattr(o, f"hydrobake_{e}", None)
                if s is not None and "superseded" in s:  # freed at the next save
                    for folder, _name in json.loads(s["superseded"]):
                        allowed.add(os.path.realpath(bpy.path.abspath(folder)))
        for folder in self.bake_folders_on_disk():
            real = os.path.realpath(folder)
            if real not in recorded and real not in allowed and not real.startswith(farm) \
                    and not self.known("orphan-folder", folder):
                raise Violation("orphan-folder",
                                f"{folder} holds {sorted(os.listdir(folder))} and no object "
                                "records it")
        self.check_copies()
        dangling = in_blender.dangling_materials(but=self.purged)
        if dangling and not self.known("dangling-material", dangling):
            raise Violation("dangling-material", f"own-material lists (index, slots) "
                            f"{dangling} point at materials removed from the file: a slot "
                            "added there shows freed memory (a segfault, or not)")
        if baked_pairs():
            self.had_bake = True
        else:  # compared with the snapshot from before the bakes, then a new one
            self.check_clean(compare=self.had_bake)
            self.take_snapshot()
            self.had_bake = False

    def check_copies(self):
        """A clean copy a bake made of a shared material (own()) looks like the artist's: its
        nodes on or off as the material's were before any bake turned them on (every flag +
        --relations 120: a copy of a material another object's bake had turned them on in
        showed default nodes, and kept them once it became the material again)."""
        for m in bpy.data.materials:
            shared = bpy.data.materials.get(m.get("hydrobake_copy_of", ""))
            if shared is None or shared.library is not None or wired(m) or \
                    "hydrobake_copy_of_made" in m:
                continue
            want = shared.use_nodes and "hydrobake_nodes_were_off" not in shared
            if m.use_nodes != want and not self.known("copy-nodes", m):
                raise Violation("copy-nodes", f"clean copy {m.name!r} has Use Nodes "
                                              f"{m.use_nodes}, its material {shared.name!r} "
                                              f"{want} without the bakes")

    def check_folder(self, name, effect, folder):
        where = f"{name}/{effect} is_baked"
        if not folder or not os.path.isdir(folder):
            raise Violation("missing-folder", f"{where} but its folder {folder!r} is missing")
        cache = BakeCache(folder)
        try:
            m = cache.read_manifest()
        except ValueError as exc:
            raise Violation("bad-manifest", f"{where}: {exc}")
        if m is None or not m.get("frames"):
            raise Violation("bad-manifest", f"{where}: no manifest or no frames in {folder}")
        if m.get("effect") != effect:
            raise Violation("bad-manifest", f"{where}: manifest of {m.get('effect')!r}")
        frames = sorted(int(f) for f in m["frames"])
        if frames != list(range(m["frame_start"], m["frame_start"] + len(frames))):
            raise Violation("bad-manifest", f"{where}: frames {frames} not an unbroken run")
        if m.get("complete") and frames[-1] != m["frame_end"]:
            raise Violation("bad-manifest", f"{where}: complete but frames {frames}, "
                                            f"frame_end {m['frame_end']}")
        listed = {"manifest.json"}
        for f, files in m["frames"].items():
            for fn, digest in files.items():
                listed.add(fn)
                p = os.path.join(folder, fn)
                if not os.path.isfile(p):
                    raise Violation("missing-file", f"{where}: frame {f}: {fn} missing")
                if file_checksum(p) != digest:
                    raise Violation("bad-checksum", f"{where}: frame {f}: {fn} sha256 differs")
        for f, c in m.get("checkpoints", {}).items():
            listed.add(c["file"])
            p = os.path.join(folder, c["file"])
            if not os.path.isfile(p) or file_checksum(p) != c["sha256"]:
                raise Violation("bad-checkpoint", f"{where}: checkpoint {f} missing or damaged")
        extra = sorted(set(os.listdir(folder)) - listed)
        if extra:
            raise Violation("unlisted-files", f"{where}: {folder} also holds {extra}")

    def bake_folder_roots(self):
        roots = {self.farm}
        for o in bpy.data.objects:
            for e in EFFECTS:
                s = getattr(o, f"hydrobake_{e}", None)
                if s is not None:
                    roots.add(bpy.path.abspath(s.cache_dir or "//hydrobake_cache/"))
        self.roots_seen |= roots
        return set(self.roots_seen)

    def bake_folders_on_disk(self):
        out = []
        for root in self.bake_folder_roots():
            if not os.path.isdir(root):
                continue
            for stem in sorted(os.listdir(root)):
                top = os.path.join(root, stem)
                if os.path.isdir(top):
                    out += [os.path.join(top, leaf) for leaf in sorted(os.listdir(top))
                            if os.path.isdir(os.path.join(top, leaf))]
        return out

    def only_orphans_hold(self, mat):
        """Whether only meshes of deleted objects (unused until the save drops them) use
        ``mat``: a baked object deleted (--delete-baked) leaves its wiring there, and once
        the file is saved and opened again such a material is used by nothing."""
        orphans = sum(me.materials[:].count(mat) for me in bpy.data.meshes  # (a user a slot)
                      if me.users == 0)
        return 0 < mat.users == orphans or (self.delete_baked and mat.users == 0)

    def image_only_orphans_hold(self, img):
        """Whether only materials that only deleted objects' meshes use show ``img`` (or,
        after the file was saved and opened again, nothing)."""
        nodes = [(m, n) for m in bpy.data.materials if m.node_tree
                 for n in m.node_tree.nodes if getattr(n, "image", None) == img]
        if not nodes:
            return self.delete_baked and img.users == 0
        return img.users <= len(nodes) and all(self.only_orphans_hold(m) for m, _n in nodes)

    def of_deleted(self, name, what="material"):
        """Whether ``name`` (HBK_<bake>_...) is of a bake whose object was deleted while baked
        (--delete-baked): by design its wiring stays in the materials it showed (a change
        made after the delete's undo step would not be undone with it) until Remove Deleted
        Objects' Bakes; a fluid domain's surface and volume objects with their materials
        stay."""
        if what == "object":
            name = made_name(name)
        if self.removed_deleted and not name.endswith(
                {"object": ("_surface", "_volume"), "material": ("_textured", "_volume")}.get(
                    what, ())):
            return False
        return any(name.startswith(f"HBK_{n}_") for n in self.deleted_bakes)

    def do_remove_deleted(self):
        self.removed_deleted = True
        return bpy.ops.hydrobake.remove_deleted_bakes()

    def shows_deleted(self, mat):
        if self.removed_deleted or mat is None or mat.node_tree is None:
            return False
        images = [n.image.name for n in mat.node_tree.nodes
                  if n.get("hydrobake") and getattr(n, "image", None) is not None]
        return bool(images) and all(self.of_deleted(i) for i in images)

    def waits_for_deleted(self, mat):
        """Whether a deleted object's bake shows in the material, or it is a clean copy whose
        shared material shows one: Remove Deleted Objects' Bakes puts it back (stands_for)."""
        shared = bpy.data.materials.get(mat.get("hydrobake_copy_of", "")) \
            if mat is not None else None
        return self.shows_deleted(mat) or (shared is not None and self.shows_deleted(shared)
                                           and not wired(mat))

    def stands_for(self, mat):
        """slot_name(), but a clean copy whose shared material shows a bake of an object
        deleted while baked is that material: by design the copy stands in the slot until
        Remove Deleted Objects' Bakes takes the wiring out (seeds 767, 769). A material made
        for a deleted object's bake, or a copy of one, is DROPPED: its slot goes with it (790),
        unless another slot follows it (obj_state), or EMPTIED where it filled the artist's
        empty slot (7206); so is a material made for a bake that only a deleted object's bake
        wires now (an Alt+D copy's: the next bake of the object takes it over and its Free
        takes it out, 7281), and a clean copy of one (1673). A clean copy whose shared
        material has left the file is that material."""
        if mat is not None and self.of_deleted(mat.get("hydrobake_copy_of", mat.name)):
            return _gone_with(mat.get("hydrobake_made", mat.get("hydrobake_copy_of_made")))
        if mat is not None and "hydrobake_made" in mat and self.shows_deleted(mat):
            return _gone_with(mat["hydrobake_made"])
        if mat is not None and "hydrobake_copy_of" in mat and \
                bpy.data.materials.get(mat["hydrobake_copy_of"]) is None and \
                "hydrobake_copy_of_made" not in mat and (self.shows_deleted(mat) or (
                    mat.get("hydrobake_link_was") != "DATA" and not wired(mat))):
            # its shared material left the file (unused at a save): the next put-back makes
            # it that material again (materials._shared_again; monkey 7148), once a deleted
            # object's wiring copied into it is taken out (Remove Deleted Objects' Bakes: 7283;
            # on a shared mesh's slot, the mesh's copy of it shows again: _mesh_slot_again)
            return mat["hydrobake_copy_of"]
        shared = bpy.data.materials.get(mat["hydrobake_copy_of"]) \
            if mat is not None and "hydrobake_copy_of" in mat else None
        if shared is not None and self.waits_for_deleted(mat):
            # (a copy with only a deleted object's wiring in it, another effect's copied with
            # it or the copy that object's bake made: Remove Deleted Objects' Bakes takes the
            # wiring out and gives the shared one back, as a bake of this object's does,
            # 7283, --relations 35)
            return _gone_with(shared["hydrobake_made"]) if "hydrobake_made" in shared \
                else shared.name
        return slot_name(mat)

    def check_clean(self, compare=True):
        """Nothing is baked: nothing of Hydrobake's is left, and everything is as before."""
        for m in bpy.data.materials:
            if m.node_tree and not self.only_orphans_hold(m) and not self.shows_deleted(m):
                tagged = [n.name for n in m.node_tree.nodes if n.get("hydrobake")]
                if tagged and not self.known("wiring-left", m):
                    raise Violation("wiring-left", f"material {m.name!r} still has Hydrobake "
                                                   f"nodes {tagged} with nothing baked")
        for coll, what in ((bpy.data.materials, "material"), (bpy.data.images, "image"),
                           (bpy.data.objects, "object"), (bpy.data.textures, "texture")):
            left = [(b.name, b.users) for b in coll if (
                made_name(b.name) if what == "object" else b.name).startswith("HBK")]
            if what == "texture":  # a pool's height texture, by the name it was baked as
                left = [(f"HBK_{t['hydrobake_heights_of']}_height"
                         if "hydrobake_heights_of" in t else name, users)
                        for name, users in left for t in [bpy.data.textures[name]]]
            if what == "material":  # by design: fluid's Free keeps its textured materials
                # unused, so that a re-bake in the session takes up the artist's edits
                left = [x for x in left if not (x[0].endswith(("_textured", "_volume")) and
                                                x[1] == 0)]
            if what == "material":  # a deleted object's mesh stays, unused, until the save
                left = [x for x in left if not self.only_orphans_hold(bpy.data.materials[x[0]])]
            if what == "image":
                left = [x for x in left if not self.image_only_orphans_hold(bpy.data.images[x[0]])]
            left = [x for x in left if not self.of_deleted(x[0], what)]
            if what == "material":  # a copy own() made, named after the shared material,
                # wired by a deleted object's bake (monkey --more --delete-baked 1696), or a
                # clean one standing for a material that is (1673: see stands_for)
                left = [x for x in left if not self.shows_deleted(bpy.data.materials[x[0]])
                        and not self.shows_deleted(bpy.data.materials.get(
                            bpy.data.materials[x[0]].get("hydrobake_copy_of", "")))]
            if what == "material":  # the shared flake material of a deleted object's flakes
                users = bpy.data.user_map(subset=[bpy.data.materials[x[0]] for x in left])
                left = [x for x in left if not users[bpy.data.materials[x[0]]] or not all(
                    self.of_deleted(u.name, "object") for u in users[bpy.data.materials[x[0]]])]
            if what == "material":  # given to another object by the artist (Link Materials,
                # Join): the artist's then, and a bake's copy of one goes back to it
                left = [x for x in left if not x[0].startswith(tuple(self.given_hbk))]
            left = [x for x in left if not self.known(f"hbk-{what}-left", x)]
            if left:
                raise Violation(f"hbk-{what}-left", f"with nothing baked: {left}")
        for o in bpy.data.objects:
            mods = [m.name for m in o.modifiers if m.name.startswith("HBK")]
            if mods and not self.of_deleted(o.name, "object"):  # (a deleted one's flakes)
                raise Violation("hbk-modifier-left", f"{o.name}: {mods}")
        if not compare:
            return
        for name, want in self.snap_objs.items():
            o = bpy.data.objects.get(name)
            if o is None:
                continue
            have = obj_state(o, self.stands_for, self.waits_for_deleted)
            for aspect in want:
                if (name, aspect) in self.dirty or aspect == "slots_alt" or \
                        (aspect == "behind" and (name, "slots") in self.dirty):
                    continue
                given = tuple(self.given_hbk)
                if aspect in ("slots", "behind", "mesh") and given and any(
                        n is not None and n.startswith(given)
                        for _l, n in want["slots"] + have["slots"]):
                    continue  # a bake's material the artist gave it: it may go with the bake
                if aspect == "slots" and {repr(have["slots"]), repr(have["slots_alt"])} & \
                        {repr(want["slots"]), repr(want["slots_alt"])}:
                    continue
                # A clean copy in the snapshot (given by the artist while nothing was baked) is
                # due to go: any Free puts its shared material back in its place (materials.
                # put_back_others), the object's own too (seed 2 of caustics,snow --more
                # --renames), or makes it that material, named so, if that left the file
                # (materials._shared_again: every flag + --scene --external --relations 818).
                if aspect == "slots" and len(have["slots"]) == len(want["slots"]) and all(
                        h == w or (w[1] and w[1].endswith(" (a copy)") and
                                   h == (w[0], w[1][:-len(" (a copy)")]))
                        for h, w in zip(have["slots"], want["slots"])):
                    continue
                if aspect == "mesh" and want["mesh"] and have["mesh"] and \
                        stale_mark_gone(have["mesh"], want["mesh"]):
                    continue
                if have[aspect] != want[aspect] and \
                        not self.known(f"object-{aspect}", (name, have[aspect], want[aspect])):
                    raise Violation(f"object-{aspect}",
                                    f"{name}: {aspect} {have[aspect]} after everything was "
                                    f"freed, was {want[aspect]} before the bakes")
        for name, want in self.snap_mats.items():
            m = bpy.data.materials.get(name)
            if m is None or ("mat", name) in self.dirty or self.only_orphans_hold(m) or \
                    self.shows_deleted(m):  # (given to another object since: seed 560)
                continue  # (a deleted baked object's material keeps its bake, unused)
            have = mat_state(m)
            if have != want and not self.known("material-state", m):
                diff = {k: (have.get(k), want.get(k)) for k in set(have) | set(want)
                        if have.get(k) != want.get(k)}
                raise Violation("material-state",
                                f"material {name!r} after everything was freed differs from "
                                f"before the bakes: (now, before) {diff}")

    def take_snapshot(self):
        self.snap_objs = {o.name: obj_state(o, self.stands_for, self.waits_for_deleted)
                          for o in scene_objects()}
        # (not one a deleted object's bake is in: not the artist's state, seeds 783, 787; nor
        # a clean copy waiting for that bake's removal, whose name a later copy may take once
        # it is gone: every flag + --relations 106)
        self.snap_mats = {m.name: mat_state(m) for m in bpy.data.materials
                          if not self.waits_for_deleted(m) and not self.only_orphans_hold(m)}
        self.dirty = set()
        self.copies = {}

    def only_copies_use(self, mat_name):
        users = [o.name for o in bpy.data.objects
                 if any(s.material and s.material.name == mat_name for s in o.material_slots)]
        return bool(users) and all(u in self.all_copies for u in users)

    def touched(self, name, aspect):
        """An artist's edit of ``name`` while something is baked: its before-state no longer
        says what Free should give back."""
        if baked_pairs():
            self.dirty.add((name, aspect))

    def touched_slots(self, obj, aspects=("slots",)):
        """touched() for the object's slots, which show on every object of its mesh (Alt+D);
        and other ``aspects`` of them (the mesh, what lies behind its slots)."""
        for o in bpy.data.objects:
            if o == obj or o.data == obj.data:
                for aspect in aspects:
                    self.touched(o.name, aspect)

    # --- running actions --------------------------------------------------------------------
    def run_action(self, a):
        op = a["op"]
        fn = getattr(self, f"do_{op}")
        with captured() as (out, err):
            try:
                result = fn(**{k: v for k, v in a.items() if k != "op"})
            except (Violation, Skip):
                raise
            except REFUSALS as exc:
                result = f"refused: {type(exc).__name__}: {exc}"
                self.check_refusal(exc)
            except Exception as exc:
                raise Violation("exception", f"{type(exc).__name__}: {exc}\n"
                                             f"{traceback.format_exc()}")
        text = out.getvalue() + err.getvalue()
        if "Traceback (most recent call last)" in text:
            raise Violation("traceback-printed", text[text.index("Traceback"):][:3000])
        return result

    def check_refusal(self, exc):
        msg = str(exc).strip()
        names = {o.name for o in bpy.data.objects} | self.used_names
        words = ("Save the .blend", "frame", "Free the bake", "cannot resume", "--", "setting",
                 "folder", "effect", "preset", "needs", "Cell Size", "Sun", "Ground", "Wipers",
                 "UV", "material", "texture")
        if not msg or not (any(n and n in msg for n in names) or any(w in msg for w in words)):
            raise Violation("unclear-refusal", f"{type(exc).__name__}: {msg!r}")

    def obj(self, name):
        o = bpy.data.objects.get(name)
        if o is None:
            raise Skip(f"no object {name}")
        return o

    def do_bake(self, name, effect, resume=False):
        self.obj(name)
        r = bpy.ops.hydrobake.bake(effect=effect, object_name=name, resume=resume)
        if effect == "caustics" and r == {"FINISHED"}:
            self.check_floors(name)
        return str(r)

    def check_floors(self, name):
        """After a pool's bake its floor nodes are in its ground's materials only, in any
        form (shown, behind a slot's Link, the shared one a copy there stands for): a ground
        it had before (renamed since) or a material swapped out of it shows them no more."""
        g = bpy.data.objects[name].hydrobake_caustics.ground_object
        have = set()
        if g is not None and g.type == "MESH":
            have = {s.material for s in g.material_slots} | set(g.data.materials)
            for s in g.material_slots:
                was = s.link
                s.link = "OBJECT" if was == "DATA" else "DATA"
                have.add(s.material)
                s.link = was
        todo = [m for m in have if m is not None]
        while todo:
            shared = bpy.data.materials.get(todo.pop().get("hydrobake_copy_of", ""))
            if shared is not None and shared not in have:
                have.add(shared)
                todo.append(shared)
        stray = sorted(m.name for m in bpy.data.materials if m not in have and m.node_tree and
                       any(n.get("hydrobake") == "caustics.multiply" and
                           n.get("hydrobake_owner") == name for n in m.node_tree.nodes))
        if stray and not self.known("floor-elsewhere", (name, stray)):
            raise Violation("floor-elsewhere", f"{name}'s floor nodes in {stray} after its "
                                               f"bake, not of its ground {g and g.name}")

    def do_free(self, name, effect):
        self.obj(name)
        return self.free(name, effect)

    def do_free_all(self):
        for name, effect in sorted(baked_pairs()):
            if bpy.data.objects.get(name) is not None and \
                    getattr(bpy.data.objects[name], f"hydrobake_{effect}").is_baked:
                self.free(name, effect)
        return "ok"

    def free(self, name, effect):
        """Free Bake; it takes out its own bake's wiring (and that of the bakes it replaced),
        no other: a bake shown before shows after (a baked object's material the artist gave
        this one, through Link Materials or Join: --scene --external 900)."""
        s = getattr(bpy.data.objects[name], f"hydrobake_{effect}")
        mine = {s.get("baked_as") or name} | {n for _f, n in jobs._superseded(s)}
        cls = hb_effects.get(effect)
        before = cls.shown_in()
        r = bpy.ops.hydrobake.free_bake(effect=effect, object_name=name)
        lost = sorted(before - cls.shown_in() - mine)
        if lost and not self.known("free-took-others", (name, effect, lost)):
            raise Violation("free-took-others", f"Free of {name}/{effect} took the wiring of "
                                                f"{lost} out (its own: {sorted(mine)})")
        return str(r)

    def do_cancel(self, name, effect, after):
        """A bake cancelled after ``after`` frames (0: before it began), as Esc does: the
        runner's cancel from the bake's own thread once the frames are recorded."""
        obj = self.obj(name)
        if (name, effect) in jobs.ACTIVE:
            raise Skip("running")
        try:
            job = jobs.Job(bpy.context, obj, effect)
        except (errors.HydrobakeError, paths.CacheFolderError, KeyError, ValueError) as exc:
            return f"refused: {exc}"  # what the operator reports
        jobs.ACTIVE[job.key] = job

        def on_frame(state):
            if state.done >= after:
                job.runner.cancel()
        job.runner.on_frame = on_frame
        if after == 0:
            job.runner.cancel()
        job.runner.start()
        if not job.runner.join(600):
            raise Violation("hang", f"{name}/{effect}: bake did not stop after cancel")
        job.finalize(bpy.context)
        s = job.runner.state
        if s.status == "FAILED":
            raise RuntimeError(f"{name} {effect}: {s.message}")
        return f"{s.status} done={s.done}"

    def do_set(self, name, effect, key, value):
        obj = self.obj(name)
        target = getattr(obj, f"hydrobake_{effect}")
        *path, attr = key.split(".")
        for p in path:
            target = getattr(target, p)
        if attr.endswith("_object") or attr == "liquid_domain":
            value = bpy.data.objects.get(value) if value else None
        if attr == "texture_size":
            target.texture_width = target.texture_height = value
            return "ok"
        if attr == "texture_scale0":
            target.texture_scale[0] = value
            return "ok"
        if attr == "cache_dir":  # a bake sent to another folder on purpose replaces nothing
            value = os.path.join(self.tmp, "abs_cache", "") if value == "ABS" else value
            if target.is_baked:
                self.output_orphans.add(os.path.realpath(target.bake_folder))
        setattr(target, attr, value)
        return "ok"

    def do_preset(self, name, effect, preset):
        self.obj(name)
        r = bpy.ops.hydrobake.apply_preset(effect=effect, object_name=name, preset=preset)
        return str(r)

    def do_copy(self, name, linked=False):
        """Shift+D, or Alt+D (``linked``: the copy shares the mesh, its slots among them)."""
        obj = self.obj(name)
        if not obj.visible_get():
            raise Skip("hidden: cannot be selected")
        if is_liquid_domain(obj):
            # Blender 3.4's Mantaflow is not safe with several liquid domains (Blender's, not
            # the addon's: upstream/mantaflow_domain_copies.py).
            raise Skip("a liquid domain: Blender 3.4's Mantaflow is not safe with several")
        select_alone(obj)
        assert bpy.ops.object.duplicate(linked=linked) == {"FINISHED"}
        copy = bpy.context.view_layer.objects.active
        self.all_copies.add(copy.name)
        src = self.copies.get(name, name)
        self.copies[copy.name] = src
        if any(d[0] == src for d in self.dirty):
            for d in list(self.dirty):
                if d[0] == src:
                    self.dirty.add((copy.name, d[1]))
        return copy.name

    def do_rename(self, name, new):
        obj = self.obj(name)
        before = {o.as_pointer(): o.name for o in bpy.data.objects}
        helper = made_name(name).startswith("HBK")
        if not helper:  # (a helper's name is not used again: see RENAMED)
            self.used_names.add(name)
        obj.name = new
        new = obj.name  # Blender may have added .001
        if helper:
            RENAMED[new] = RENAMED.pop(name, name)
        else:
            self.used_names.add(new)
        # ... or given the name to this object and .001 to the one that had it (3.4 does).
        moved = {before[o.as_pointer()]: o.name for o in bpy.data.objects
                 if before.get(o.as_pointer(), o.name) != o.name}
        for old, now in moved.items():  # a renamed helper that gave its name up
            if old in RENAMED and now not in RENAMED:
                RENAMED[now] = RENAMED.pop(old)
        self.snap_objs = {moved.get(k, k): v for k, v in self.snap_objs.items()}
        self.dirty = {(moved.get(n, n), a) for n, a in self.dirty}
        self.all_copies |= {moved[n] for n in self.all_copies if n in moved}
        self.copies = {moved.get(k, k): moved.get(v, v) for k, v in self.copies.items()}
        return new

    def do_rename_texture(self, name, new):
        tex = bpy.data.textures.get(name)
        if tex is None:
            raise Skip(f"no texture {name}")
        tex.name = new
        return tex.name

    def do_rename_modifier(self, name, modifier, new):
        mod = self.obj(name).modifiers.get(modifier)
        if mod is None:
            raise Skip(f"no modifier {modifier}")
        mod.name = new
        return mod.name

    def do_delete(self, name):
        obj = self.obj(name)
        self._gone(obj)
        if not obj.visible_get():
            bpy.data.objects.remove(obj)
            bpy.context.view_layer.update()  # as the UI evaluates after every change
            return "removed (hidden)"
        select_alone(obj)
        assert bpy.ops.object.delete() == {"FINISHED"}
        bpy.context.view_layer.update()
        return "deleted"

    def _gone(self, obj):
        """The bookkeeping of an object about to leave the file (deleted, joined)."""
        name = obj.name
        self.snap_objs.pop(name, None)  # (another object may take the name: seed 643)
        baked = [e for e in EFFECTS if getattr(obj, f"hydrobake_{e}").is_baked]
        if baked and not self.delete_baked:
            for e in baked:  # the artist frees it first
                bpy.ops.hydrobake.free_bake(effect=e, object_name=name)
        for e in EFFECTS:
            s = getattr(obj, f"hydrobake_{e}")
            if s.is_baked and not jobs.holders(s.bake_folder, e, but=obj):
                self.abandoned.add(s.bake_folder)
                self.deleted_bakes.add(s.get("baked_as") or name)
                # and the bakes it replaced under older names, kept until the next save
                self.abandoned.update(f for f, _ in jobs._superseded(s))

    def do_material(self, name, kind, slot, material, nodes=True):
        obj = self.obj(name)
        self.touched_slots(obj)
        if kind == "add":
            obj.active_material_index = max(0, len(obj.material_slots) - 1)
            with bpy.context.temp_override(object=obj):
                bpy.ops.object.material_slot_add()
            slot = len(obj.material_slots) - 1
            kind = "change"
        if slot >= len(obj.material_slots):
            raise Skip("no such slot")
        if kind == "remove":
            if obj.type == "MESH" and len(obj.material_slots) != len(obj.data.materials):
                # Blender 3.4.1 takes a user from the mesh's first material and leaves it
                # there, with or without the addon, and a save then drops it (monkey --more
                # --delete-baked --relations --no-subprocess 100; upstream/slot_remove_lagging.py)
                raise Skip("the object's slots lag its mesh's")
            obj.active_material_index = slot
            with bpy.context.temp_override(object=obj):
                bpy.ops.object.material_slot_remove()
            return "removed"
        mat = None
        if material:
            mat = bpy.data.materials.get(material)
            if mat is None:
                mat = user_material(material, nodes=nodes)
                if not baked_pairs():
                    self.snap_mats[mat.name] = mat_state(mat)
                else:  # made now: its before-state is this one
                    self.snap_mats[mat.name] = mat_state(mat)
        obj.material_slots[slot].material = mat
        return "changed"

    def do_modifier(self, name, kind, index=0, mtype="SOLIDIFY", attr="show_render"):
        obj = self.obj(name)
        self.touched(name, "mods")
        if kind == "add":
            mod = obj.modifiers.new(f"User {mtype.title()}", mtype)
            if mtype == "SUBSURF":
                mod.levels = mod.render_levels = 1
            if mtype == "SOLIDIFY":
                mod.thickness = 0.01
            if mtype == "WAVE":
                mod.height = 0.05
            return mod.name
        if index >= len(obj.modifiers):
            raise Skip("no such modifier")
        mod = obj.modifiers[index]
        if kind == "remove":
            obj.modifiers.remove(mod)
            return "removed"
        setattr(mod, attr, not getattr(mod, attr))
        return "toggled"

    def _slot_op(self, obj, slot, op, **kw):
        """A slot operator of the Material panel on ``obj`` with slot ``slot`` active."""
        self.touched_slots(obj)
        obj.active_material_index = slot
        with bpy.context.temp_override(object=obj, active_object=obj,
                                       selected_editable_objects=[obj]):
            return op(**kw)

    def do_slot_move(self, name, slot, direction):
        """A slot moved up or down the list (Material panel's arrows): the faces follow it."""
        obj = self.obj(name)
        if slot >= len(obj.material_slots) or len(obj.material_slots) < 2:
            raise Skip("no slot to move")
        if obj.type == "MESH" and len(obj.material_slots) != len(obj.data.materials):
            # Blender 3.4.1 writes past the object's slots then, with or without the addon
            # (monkey --more --elsewhere --moves 4055; upstream/slot_move_overflow.py)
            raise Skip("the object's slots lag its mesh's")
        done = self._slot_op(obj, slot, bpy.ops.object.material_slot_move, direction=direction)
        return f"moved {direction}" if done == {"FINISHED"} else "not moved"

    def do_slots_tidy(self, name):
        """Remove Unused Slots (Material panel's menu): slots no face uses go."""
        obj = self.obj(name)
        if not obj.material_slots:
            raise Skip("no slots")
        before = len(obj.material_slots)
        # (it works on the view layer's active and selected objects, whatever the context)
        if obj.name not in bpy.context.view_layer.objects or not obj.visible_get():
            raise Skip("not selectable")
        select_alone(obj)
        self._slot_op(obj, 0, bpy.ops.object.material_slot_remove_unused)
        return f"{before} -> {len(obj.material_slots)} slots"

    def _selectable(self, *objs):
        for o in objs:
            if o.name not in bpy.context.view_layer.objects or not o.visible_get():
                raise Skip(f"{o.name} not selectable")
            if o.type != "MESH":
                raise Skip(f"{o.name} is no mesh")

    def do_join(self, name, into):
        """Ctrl+J: ``name`` joined into ``into`` (active). The artist frees its bakes first,
        unless --delete-baked: then, as a delete, its bake stays till Remove Deleted Objects'
        Bakes. ``into`` takes its faces and materials: its slots are the artist's edit."""
        src, dst = self.obj(name), self.obj(into)
        if src == dst:
            raise Skip("joined into itself")
        self._selectable(src, dst)
        self.touched_slots(dst, MESH_ASPECTS)
        self._gone(src)
        select_alone(dst, also=src)
        r = bpy.ops.object.join()
        bpy.context.view_layer.update()
        self.given(dst)
        return f"joined: {r}"

    def do_single_user(self, name):
        """Object > Relations > Make Single User > Object & Data: an Alt+D copy gets a mesh
        of its own (and a copy of the object where another scene had it)."""
        obj = self.obj(name)
        self._selectable(obj)
        self.touched_slots(obj, MESH_ASPECTS)
        select_alone(obj)
        r = bpy.ops.object.make_single_user(type="SELECTED_OBJECTS", object=True, obdata=True)
        return f"{r}: {obj.data.users} user(s)"

    def do_link_materials(self, name, into):
        """Ctrl+L > Link Materials: ``into`` (selected) takes the slots and materials of
        ``name`` (active), a bake's copy among them."""
        src, dst = self.obj(name), self.obj(into)
        if src == dst:
            raise Skip("linked to itself")
        self._selectable(src, dst)
        # (the mesh's materials are the artist's now: the mark of a slot kept empty stays
        # for a bake's copy given, seed 14)
        self.touched_slots(dst, MESH_ASPECTS)
        select_alone(src, also=dst)
        r = bpy.ops.object.make_links_data(type="MATERIAL")
        self.given(dst)
        return str(r)

    def given(self, obj):
        """The HBK materials ``obj`` shows now, and what the copies among them stand for. (A
        material with another bake's wiring keeps it through ``obj``'s Free: free().)"""
        mats = [m for m in obj.data.materials if m] + \
            [s.material for s in obj.material_slots if s.material]
        self.given_hbk |= {n for m in mats for n in (m.name, m.get("hydrobake_copy_of", ""))
                           if n.startswith("HBK")}

    def do_slot_link(self, name, slot):
        """A slot switched between the mesh's material and the object's own (Link)."""
        obj = self.obj(name)
        if slot >= len(obj.material_slots):
            raise Skip("no such slot")
        self.touched(name, "slots")
        s = obj.material_slots[slot]
        s.link = "OBJECT" if s.link == "DATA" else "DATA"
        return s.link

    def do_collection(self, name, kind):
        """The object moved to a collection of its own (M), or the first collection of it
        excluded from the view layer or disabled in viewports, or back (its bake is refused
        while Blender does not evaluate it)."""
        obj = self.obj(name)
        scene = bpy.context.scene
        # Hidden (H) is a flag of the object's place in the view layer: a move gives it a new
        # one, an excluded collection none (hide_get is False then): Blender's, not a bake's
        # (monkey 7065).
        self.touched(name, "vis")
        if kind == "move":
            self.counter += 1
            coll = bpy.data.collections.new(f"Coll{self.counter}")
            scene.collection.children.link(coll)
            for c in list(obj.users_collection):
                c.objects.unlink(obj)
            coll.objects.link(obj)
            return coll.name
        coll = next((c for c in obj.users_collection if c != scene.collection), None)
        if coll is None:
            raise Skip("in the scene's own collection only")
        for o in coll.all_objects:  # (every object in it: Shift+D copies share it, 7164)
            self.touched(o.name, "vis")
        if kind == "exclude":
            lc = _layer_collection(bpy.context.view_layer.layer_collection, coll)
            if lc is None:
                raise Skip("not in the view layer")
            lc.exclude = not lc.exclude
            return f"{coll.name} exclude={lc.exclude}"
        coll.hide_viewport = not coll.hide_viewport
        return f"{coll.name} hide_viewport={coll.hide_viewport}"

    def do_visibility(self, name, attr):
        obj = self.obj(name)
        self.touched(name, "vis")
        if attr == "hide_set":
            obj.hide_set(not obj.hide_get())
        else:
            setattr(obj, attr, not getattr(obj, attr))
        return "toggled"

    def do_frame(self, frame):
        bpy.context.scene.frame_set(frame)
        return "ok"

    def do_save(self):
        bpy.ops.wm.save_mainfile()
        return "saved"

    def do_reopen(self):
        bpy.ops.wm.save_mainfile()
        bpy.ops.wm.open_mainfile(filepath=self.blend)
        return "reopened"

    def do_save_as(self, folder, copy=False, remap=True):
        """File > Save As (or Save Copy, then opening the copy) into ``folder`` of the run's,
        with Remap Relative on or off."""
        self.left_behind |= {os.path.realpath(f) for f in self.bake_folders_on_disk()}
        where = os.path.join(self.tmp, folder)
        os.makedirs(where, exist_ok=True)
        path = os.path.join(where, "monkey.blend")
        bpy.ops.wm.save_as_mainfile(filepath=path, copy=copy, relative_remap=remap)
        if copy:
            bpy.ops.wm.open_mainfile(filepath=path)
        if remap:  # the paths rewritten to name the same files (as do_paths): a packed block
            self._packed_paths_rewritten()  # an unremapped save moved stays moved (972)
        self.blend = path
        return f"saved {'a copy ' if copy else ''}in {folder or '.'}"

    def do_fps(self, fps):
        """Output Properties > Frame Rate."""
        bpy.context.scene.render.fps = fps
        return "ok"

    def do_scene_range(self, name, effect, use, end):
        """The scene's End frame, and whether the object's effect bakes the scene's range."""
        bpy.context.scene.frame_end = end
        getattr(self.obj(name), f"hydrobake_{effect}").use_scene_range = use
        return "ok"

    def do_paths(self, kind):
        """File > External Data > Make Paths Absolute / Relative."""
        result = str(getattr(bpy.ops.file, f"make_paths_{kind}")())
        self._packed_paths_rewritten()
        return result

    def _packed_paths_rewritten(self):
        """The packed blocks' paths, written another way for the same files: see check."""
        for b in self.packable():
            key = (type(b).__name__, b.name)
            if key in self.packed_from:
                self.packed_from[key] = (b.filepath, self.packed_from[key][1])

    def do_pack(self, kind):
        """File > External Data > Pack Resources, or Unpack Resources with ``kind``'s method."""
        if kind == "pack":
            try:
                before = {(type(b).__name__, b.name) for b in self.packable() if b.packed_file}
                result = str(bpy.ops.file.pack_all())
                for b in self.packable():
                    if b.packed_file and (type(b).__name__, b.name) not in before:
                        self.packed_from[(type(b).__name__, b.name)] = (
                            b.filepath, os.path.realpath(bpy.path.abspath(b.filepath)))
                return result
            except RuntimeError as exc:  # Blender's: a file missing; the artist's, it may be
                missing = re.findall(r"source path '(.*?)' not found", str(exc))
                if missing and not any(paths_inside(p, self.bake_folder_roots())
                                       for p in missing):  # (unpacked here, then saved
                    return f"not packed: {sorted(set(missing))}"  # elsewhere unremapped)
                raise Violation("pack", f"Pack Resources: {exc}") from exc
        if not any(b.packed_file for b in (*bpy.data.images, *bpy.data.volumes)):
            raise Skip("nothing packed")
        return str(bpy.ops.file.unpack_all(method=kind))

    @staticmethod
    def packable():
        return (*bpy.data.images, *bpy.data.volumes)

    def do_purge(self):
        """File > Clean Up > Purge Unused Data (recursive). Blender's purge leaves the own-
        material lists past objects' slots pointing at what it removed, as the addon's Free
        did (its own bug, the artist's action): those addresses are not the addon's."""
        self.purged.update(m.as_pointer() for m in bpy.data.materials)
        done = str(bpy.ops.outliner.orphans_purge(do_local_ids=True, do_linked_ids=True,
                                                  do_recursive=True))
        self.purged.difference_update(m.as_pointer() for m in bpy.data.materials)
        return done

    def do_undo(self):
        if self.undo_works is False:
            raise Skip("undo does not work in background")
        try:
            bpy.ops.ed.undo()
        except RuntimeError as exc:
            if "poll" in str(exc):
                self.undo_works = False
                raise Skip("undo does not work in background")
            raise
        self.undo_works = True
        return "undone"

    def cli_argv(self, command, name, effect, frames, output):
        argv = [command]
        if command == "list":
            return argv
        if name:
            argv += ["--objects", name]
        if effect:
            argv += ["--effects", effect]
        if command in ("bake", "resume") and frames:
            argv += ["--frames", frames]
        if command in ("bake", "resume") and output:
            argv += ["--output", self.farm]
        return argv

    def do_cli(self, command, name=None, effect=None, frames=None, output=False, sub=False):
        if name and bpy.data.objects.get(name) is None:
            raise Skip(f"no object {name}")
        argv = self.cli_argv(command, name, effect, frames, output)
        if output and command == "bake":
            for o in bpy.data.objects:
                s = getattr(o, f"hydrobake_{effect}", None)
                if s is not None and s.is_baked and (o.name == name or not name):
                    self.output_orphans.add(os.path.realpath(s.bake_folder))
        if sub:
            if not self.subprocess_ok:
                raise Skip("no subprocess")
            bpy.ops.wm.save_mainfile()
            r = subprocess.run([BATCH, self.blend, *argv], capture_output=True, text=True,
                               timeout=900, env=dict(os.environ, PYTHONPATH=""))
            code, text = r.returncode, r.stdout + r.stderr
            bpy.ops.wm.open_mainfile(filepath=self.blend)
        else:
            err = io.StringIO()
            real = sys.stderr
            try:
                sys.stderr = Tee(real)
                err = sys.stderr.buf
                try:
                    cli.main(argv)
                    code = 0
                except SystemExit as exc:
                    code = exc.code
            finally:
                sys.stderr = real
            text = err.getvalue()
        if "Traceback" in text:
            raise Violation("traceback-printed", f"cli {argv}: {text[text.index('Traceback'):][:3000]}")
        if code not in (0, 1):
            raise Violation("cli-exit", f"cli {argv} exited {code}: {text[-2000:]}")
        if code == 1:
            lines = [l for l in text.splitlines() if l.startswith("hydrobake:") and
                     ("failed:" in l or "error:" in l)]
            if not lines:
                raise Violation("cli-exit", f"cli {argv} exited 1 without saying why: "
                                            f"{text[-2000:]}")
            return f"exit 1: {lines[0]}"
        return f"exit {code}"

    # --- choosing actions -------------------------------------------------------------------
    def setting_change(self, name, effect):
        rng = self.rng
        choices = {
            "caustics": [("water.width", rng.choice((12, 16, 20))),
                         ("map_resolution", rng.choice((24, 32, 48))),
                         ("displace_surface", rng.random() < 0.5),
                         ("projector", rng.random() < 0.5),
                         ("loop", rng.random() < 0.3), ("loop_blend", 1),
                         ("ground_object", rng.choice(["Ground", None] + [
                             o.name for o in scene_objects()][:3])),
                         ("frame_end", rng.choice((2, 3, 4)))],
            "rain": [("rain.cell_size", rng.choice((0.04, 0.05, 0.0625))),
                     ("substeps", rng.choice((1, 2))),
                     ("frame_end", rng.choice((2, 3, 4)))],
            "snow": [("flake_density", rng.choice((20.0, 40.0, 80.0))),
                     ("texture_size", rng.choice((16, 24, 32))),
                     ("use_displacement", rng.random() < 0.5),
                     ("snow.contact_mode", rng.choice(("TRIANGLES", "BOX"))),
                     ("write_flakes", rng.random() < 0.5),
                     ("frame_end", rng.choice((2, 3, 4)))],
            "fluid": [("fluid.substeps", rng.choice((2, 4))),
                      ("texture_scale0", rng.choice((1.0, 2.0))),
                      ("frame_end", rng.choice((2, 3)))],
        }[effect]
        if self.sources and effect == "fluid":  # (any object may be named: a refusal then)
            choices += [("fluid.source", rng.choice(("SIMULATE", "PARTICLES", "VELOCITY_GRID"))),
                        ("particle_object", rng.choice(
                            [None] + [o.name for o in scene_objects()
                                      if o.particle_systems or rng.random() < 0.2])),
                        ("liquid_domain", rng.choice(
                            [None] + [o.name for o in scene_objects()
                                      if is_liquid_domain(o)]))]
        key, value = rng.choice(choices)
        if self.external and self.rng3.random() < 0.3:  # another Cache Folder
            return {"op": "set", "name": name, "effect": effect, "key": "cache_dir",
                    "value": self.rng3.choice(("", "//other_cache/", "ABS"))}
        if self.external and key == "frame_end" and self.rng2.random() < 0.4:
            value = 1  # one frame: a file, not a sequence, which Pack All packs
        if key == "texture_size":
            key = "snow.texture_size"
        if key == "texture_scale0":
            key = "fluid.texture_scale0"
        return {"op": "set", "name": name, "effect": effect, "key": key, "value": value}

    def new_name(self, base):
        self.counter += 1
        r = self.rng.random()
        if r < 0.15:
            return f"{base}.A" if self.rng.random() < 0.5 else f"{base} A"
        if r < 0.35 and self.used_names:
            return self.rng.choice(sorted(self.used_names))  # an old name again
        return f"{base}{self.counter}"

    def choose(self):
        """The next actions (a macro is a few an artist does in a row)."""
        rng = self.rng
        tg = targets()
        objs = [o.name for o in scene_objects()]
        if not tg:
            return [{"op": "save"}]
        name, effect = rng.choice(tg)
        frames = getattr(bpy.data.objects[name], f"hydrobake_{effect}").frame_end
        ops = [("bake", 14), ("free", 8), ("cancel", 8), ("resume", 4), ("rebake", 8),
               ("copy", 6), ("rename", 6), ("delete", 2), ("material", 6), ("modifier", 5),
               ("visibility", 4), ("save", 2), ("reopen", 3), ("undo", 1), ("cli", 6),
               ("frame", 2), ("preset", 2), ("free_all", 2)]
        if self.more:  # (an opt-in: the fixed seeds' sequences stay as they were)
            ops += [("link_copy", 4), ("slot_link", 4), ("collection", 4)]
        if self.elsewhere:
            ops += [("save_as", 4)]
        if self.moves:
            ops += [("slot_move", 5), ("slots_tidy", 2)]
        if self.relations:
            ops += [("join", 2), ("single_user", 3), ("link_materials", 3)]
        if self.external:
            ops += [("paths", 3), ("pack", 4), ("purge", 2)]
        if self.scene_ops:
            ops += [("fps", 2), ("scene_range", 4)]
        if self.renames:
            ops += [("rename_any", 4), ("rename_helper", 3), ("rename_modifier", 2),
                    ("rename_texture", 2)]
        op = rng.choices([o for o, _ in ops], [w for _, w in ops])[0]
        if op == "link_copy":
            return [{"op": "copy", "name": name, "linked": True},
                    {"op": rng.choice(("bake", "free")), "name": self._predict_copy_name(name)
                     if rng.random() < 0.6 else name, "effect": effect}]
        if op == "slot_link":
            who = rng.choice(objs)
            n = len(bpy.data.objects[who].material_slots)
            return [{"op": "slot_link", "name": who, "slot": rng.randint(0, max(0, n - 1))}]
        if op == "collection":
            return [{"op": "collection", "name": rng.choice(objs),
                     "kind": rng.choice(("move", "exclude", "hide"))}]
        if op == "slot_move":  # (an object with one slot gets a second first)
            several = [o for o in objs if len(bpy.data.objects[o].material_slots) > 1]
            who = rng.choice(several if several and rng.random() < 0.7 else objs)
            n = len(bpy.data.objects[who].material_slots)
            out = []
            if n < 2:
                mats = sorted(m.name for m in bpy.data.materials if not m.name.startswith("HBK"))
                self.counter += 1
                out.append({"op": "material", "name": who, "kind": "add", "slot": 0,
                            "material": rng.choice(mats + [f"UserMat{self.counter}", None]),
                            "nodes": True})
                n += 1
            slot = rng.randint(0, n - 1)  # (a move off the list's end does nothing)
            return out + [{"op": "slot_move", "name": who, "slot": slot, "direction": "DOWN"
                           if slot == 0 else "UP" if slot == n - 1 else rng.choice(("UP", "DOWN"))}]
        if op == "slots_tidy":
            return [{"op": "slots_tidy", "name": rng.choice(objs)}]
        if op in ("join", "link_materials"):  # (the first one selected, the second active)
            return [{"op": op, "name": rng.choice(objs), "into": rng.choice(objs)}]
        if op == "single_user":
            return [{"op": op, "name": rng.choice(objs)}]
        if op == "fps":
            return [{"op": op, "fps": rng.choice((24, 25, 30))}]
        if op == "rename_modifier":  # a pool's Subdivision or Displace, snow's BOX mode's
            # (to HBKm<n>: the addon knows them by their old name no more, and one left once
            # nothing is baked is still seen; the glass's Solidify renamed is the artist's)
            mods = [(o.name, m.name) for o in scene_objects() for m in o.modifiers
                    if m.name in ("HBK Subdivision", "HBK Displace", "HBK Snow Box") or
                    m.name.startswith("HBKm")]
            if not mods:
                return [{"op": "save"}]
            self.counter += 1
            who, mod = rng.choice(mods)
            return [{"op": op, "name": who, "modifier": mod, "new": f"HBKm{self.counter}"}]
        if op == "rename_texture":  # a pool's height texture (to HBKt<n>: still seen)
            texs = sorted(t.name for t in bpy.data.textures if t.library is None and
                          t.name.startswith("HBK"))
            if not texs:
                return [{"op": "save"}]
            self.counter += 1
            return [{"op": op, "name": rng.choice(texs), "new": f"HBKt{self.counter}"}]
        if op == "rename_helper":  # a bake's projector, grid, flakes or fluid surface
            helpers = sorted(o.name for o in bpy.data.objects if o.library is None and
                             made_name(o.name).startswith("HBK_"))
            if not helpers:
                return [{"op": "save"}]
            self.counter += 1
            return [{"op": "rename", "name": rng.choice(helpers), "new": f"Helper{self.counter}"}]
        if op == "rename_any":
            who = rng.choice(objs)
            return [{"op": "rename", "name": who, "new": self.new_name(who.split(".")[0][:6])}]
        if op == "scene_range":  # (then a bake or resume of the object, at times)
            out = [{"op": op, "name": name, "effect": effect, "use": rng.random() < 0.6,
                    "end": rng.choice((1, 2, 3, 4))}]
            if rng.random() < 0.5:
                out.append({"op": "bake", "name": name, "effect": effect,
                            "resume": rng.random() < 0.4})
            return out
        if op == "paths":
            return [{"op": op, "kind": rng.choice(("absolute", "relative"))}]
        if op == "pack":  # (unpacked beside the file: an original's place is a bake folder)
            return [{"op": op, "kind": rng.choice(("pack", "pack", "USE_LOCAL", "WRITE_LOCAL",
                                                   "REMOVE", "KEEP"))}]
        if op == "save_as":
            return [{"op": "save_as", "folder": rng.choice(("", "s1", os.path.join("s2", "deep"))),
                     "copy": rng.random() < 0.4, "remap": self.rng2.random() < 0.6}]
        if op == "bake":
            return [{"op": "bake", "name": name, "effect": effect}]
        if op == "free":
            return [{"op": "free", "name": name, "effect": effect}]
        if op == "free_all":
            return [{"op": "free_all"}]
        if op == "cancel":
            out = [{"op": "cancel", "name": name, "effect": effect,
                    "after": rng.randint(0, max(0, frames - 1))}]
            if rng.random() < 0.7:
                out.append({"op": "bake", "name": name, "effect": effect, "resume": True})
            return out
        if op == "resume":
            return [{"op": "bake", "name": name, "effect": effect, "resume": True}]
        if op == "rebake":
            out = [] if (rng.random() < 0.4) else [{"op": "free", "name": name,
                                                     "effect": effect}]
            return out + [self.setting_change(name, effect),
                          {"op": "bake", "name": name, "effect": effect}]
        if op == "copy":
            out = [{"op": "copy", "name": name}]
            # then bake or free the copy (its name is only known then) or the original
            r = rng.random()
            copy_name = self._predict_copy_name(name)
            who = copy_name if r < 0.6 else name
            out.append({"op": rng.choice(("bake", "free")), "name": who, "effect": effect})
            return out
        if op == "rename":
            return [{"op": "rename", "name": name, "new": self.new_name(name.split(".")[0][:6])}]
        if op == "delete":
            return [{"op": "delete", "name": rng.choice(objs)}]
        if op == "material":
            who = rng.choice(objs)
            nslots = len(bpy.data.objects[who].material_slots)
            kind = rng.choice(("add", "change", "change", "remove"))
            mats = sorted(m.name for m in bpy.data.materials if not m.name.startswith("HBK"))
            self.counter += 1
            material = rng.choice(mats + [f"UserMat{self.counter}"] * 2 + [None])
            return [{"op": "material", "name": who, "kind": kind,
                     "slot": rng.randint(0, max(0, nslots - 1)), "material": material,
                     "nodes": rng.random() < 0.8}]
        if op == "modifier":
            who = rng.choice(objs)
            n = len(bpy.data.objects[who].modifiers)
            kind = rng.choice(("add", "toggle", "toggle", "remove")) if n else "add"
            return [{"op": "modifier", "name": who, "kind": kind,
                     "index": rng.randint(0, max(0, n - 1)),
                     # (a Wave deforms the shape frame by frame: snow follows it, the
                     # others read it at their first frame)
                     "mtype": rng.choice(("SOLIDIFY", "SUBSURF", "TRIANGULATE", "WAVE")),
                     "attr": rng.choice(("show_render", "show_viewport"))}]
        if op == "visibility":
            attrs = ["hide_render", "visible_shadow", "hide_set", "hide_viewport"]
            attr = rng.choice(attrs)
            return [{"op": "visibility", "name": rng.choice(objs), "attr": attr}]
        if op == "frame":
            return [{"op": "frame", "frame": rng.randint(0, 5)}]
        if op == "preset":
            presets = {"caustics": ["Calm Pool", "Rainy Pond", "Dispersive"],
                       "rain": ["Drizzle", "Downpour", "Highway"],
                       "snow": ["Wet Snow (+1 °C)", "Powder (-8 °C)"],
                       "fluid": []}[effect]
            if not presets:
                return [{"op": "save"}]
            out = [{"op": "preset", "name": name, "effect": effect,
                    "preset": rng.choice(presets)}]
            if effect == "snow":  # the presets' densities bake for minutes
                out.append({"op": "set", "name": name, "effect": effect,
                            "key": "flake_density", "value": 40.0})
            return out
        if op == "cli":
            command = rng.choice(("bake", "bake", "free", "list", "resume"))
            return [{"op": "cli", "command": command, "name": name, "effect": effect,
                     "frames": rng.choice((None, "1-2")) if command == "bake" else None,
                     "output": command == "bake" and rng.random() < 0.15,
                     "sub": self.subprocess_ok and rng.random() < 0.3}]
        return [{"op": op}]

    @staticmethod
    def _predict_copy_name(name):
        """The name Shift+D will give the copy: the next free '<base>.NNN'."""
        base = name.rsplit(".", 1)[0] if name[-4:-3] == "." and name[-3:].isdigit() else name
        k = 1
        while f"{base}.{k:03d}" in bpy.data.objects:
            k += 1
        return f"{base}.{k:03d}"

    # --- the run -----------------------------------------------------------------------------
    def start(self):
        self.blend = build_scene(self.seed, self.effects, self.tmp, self.sources,
                                 self.obstacles)
        self.check("setup")

    def step(self, a, k):
        self.log.append(dict(a))
        if self.record is not None:  # a crash (Blender's own) leaves the log up to it
            path = os.path.join(self.tmp, "actions.json")
            with open(path + ".tmp", "w") as f:
                json.dump(dict(self.record, crashed_at=len(self.log)), f)
            os.replace(path + ".tmp", path)
        try:
            result = self.run_action(a)
        except Skip as s:
            result = f"skipped: {s}"
        print(f"monkey: step {k}: {json.dumps(a)} -> {result}", flush=True)
        if self.trace:
            print(f"    deleted bakes {sorted(self.deleted_bakes)}")
            for o in bpy.data.objects:
                for e in EFFECTS:
                    s = getattr(o, f"hydrobake_{e}")
                    if s.is_baked:
                        print(f"    record {o.name} {e} as={s.get('baked_as')} "
                              f"{s.bake_folder} superseded={s.get('superseded')}")
            for o in scene_objects():
                data = (f" data={o.data.name} mats={len(o.data.materials)}"
                        if o.type == "MESH" else "")
                shows = sorted({m.name for _l, m in slots_of(o) if m is not None})
                print(f"    {o.name}: {obj_state(o)} shows={shows} baked="
                      f"{[e for e in EFFECTS if getattr(o, f'hydrobake_{e}').is_baked]}{data}")
            for mat in bpy.data.materials:
                print(f"    mat {mat.name!r} users={mat.users} nodes={mat.use_nodes} "
                      f"{sorted(mat.keys())}"
                      f" tagged={[n.get('hydrobake') for n in mat.node_tree.nodes if n.get('hydrobake')] if mat.node_tree else None}")
            for img in bpy.data.images:
                if img.name.startswith("HBK"):
                    shown = [m.name for m in bpy.data.materials if m.node_tree and any(
                        getattr(n, "image", None) == img for n in m.node_tree.nodes)]
                    print(f"    image {img.name!r} users={img.users} in {shown} "
                          f"path={img.filepath!r} packed={img.packed_file is not None}")
            for vol in bpy.data.volumes:
                if vol.name.startswith("HBK"):
                    print(f"    volume {vol.name!r} users={vol.users} path={vol.filepath!r} "
                          f"packed={vol.packed_file is not None}")
            print(f"    file {bpy.data.filepath}")
        self.check(f"step {k} {a['op']}")

    def finish(self, render=True):
        k = len(self.log)
        if render:
            self.step({"op": "render"}, k)
        self.step({"op": "free_all"}, k + 1)
        if baked_pairs():  # copies' records: freed in any order, every one goes
            self.step({"op": "free_all"}, k + 2)
        if baked_pairs():
            raise Violation("cannot-free", f"still baked after Free on every record: "
                                           f"{baked_pairs()}")
        if self.deleted_bakes:  # File > Clean Up: what they left goes too
            self.step({"op": "remove_deleted"}, k + 3)
        if render:
            self.step({"op": "render"}, k + 4)

    def do_render(self):
        scene = bpy.context.scene
        if scene.camera is None:
            cams = [o for o in bpy.data.objects if o.type == "CAMERA"]
            if not cams:
                raise Skip("no camera")
            scene.camera = cams[0]
        scene.render.engine = "CYCLES"
        scene.cycles.samples = 1
        scene.cycles.use_denoising = False
        scene.cycles.device = "CPU"
        scene.render.resolution_x = scene.render.resolution_y = 32
        scene.render.resolution_percentage = 100
        out = os.path.join(self.tmp, "render.png")
        if os.path.exists(out):
            os.remove(out)
        scene.render.filepath = out
        bpy.ops.render.render(write_still=True)
        if not os.path.isfile(out):
            raise Violation("render", "Cycles wrote no image")
        img = bpy.data.images.load(out)
        size = tuple(img.size)
        bpy.data.images.remove(img)
        if size != (32, 32):
            raise Violation("render", f"render is {size}")
        return "rendered"


class Skip(Exception):
    pass


def main():
    p = argparse.ArgumentParser()
    p.add_argument("tmp")
    p.add_argument("seed", type=int)
    p.add_argument("--steps", type=int, default=20)
    p.add_argument("--effects", default=None)
    p.add_argument("--replay", default=None)
    p.add_argument("--delete-baked", action="store_true")
    p.add_argument("--no-subprocess", action="store_true")
    p.add_argument("--no-render", action="store_true")
    p.add_argument("--more", action="store_true",
                   help="also Alt+D copies, slot links and collections (moved, excluded)")
    p.add_argument("--elsewhere", action="store_true",
                   help="also Save As and Save Copy (opened) into other folders")
    p.add_argument("--moves", action="store_true",
                   help="also slots moved up and down and Remove Unused Slots")
    p.add_argument("--relations", action="store_true",
                   help="also Join, Make Single User and Link Materials")
    p.add_argument("--external", action="store_true",
                   help="also paths made absolute / relative, Pack / Unpack, Purge Unused")
    p.add_argument("--scene", action="store_true",
                   help="also the scene's frame rate and End frame, and Use Scene Range")
    p.add_argument("--sources", action="store_true",
                   help="also a particle emitter and a baked Mantaflow liquid, the fluid's "
                        "source switched among them")
    p.add_argument("--obstacles", action="store_true",
                   help="also the fluid's obstacles (a still rock, a keyed paddle, a cone, a "
                        "swelling hoop, a metaball family's drifting member), its water poured "
                        "as a ball, and a pool's floor keyed to sink")
    p.add_argument("--renames", action="store_true",
                   help="also any object renamed (a pool's ground, a collider, a bake's helpers)")
    p.add_argument("--trace", action="store_true", help="print the objects after each step")
    p.add_argument("--known", action="store_true",
                   help="do not fail on the violations in KNOWN (already reported)")
    args = p.parse_args(in_blender.args())
    tmp = os.path.abspath(args.tmp)
    os.makedirs(tmp, exist_ok=True)
    replay = None
    if args.replay:
        with open(args.replay) as f:
            replay = json.load(f)
        effects = replay["effects"]
    elif args.effects:
        effects = args.effects.split(",")
    else:
        r = random.Random(args.seed * 31 + 7)
        effects = [e for e in EFFECTS if r.random() < 0.6] or [r.choice(EFFECTS)]
    effects = [e for e in EFFECTS if e in effects]
    m = Monkey(args.seed, tmp, effects, subprocess_ok=not args.no_subprocess,
               delete_baked=args.delete_baked or bool(replay and replay.get("delete_baked")))
    m.mask_known = args.known
    m.trace = args.trace
    m.more = args.more or bool(replay and replay.get("more"))
    m.elsewhere = args.elsewhere or bool(replay and replay.get("elsewhere"))
    m.moves = args.moves or bool(replay and replay.get("moves"))
    m.relations = args.relations or bool(replay and replay.get("relations"))
    m.external = args.external or bool(replay and replay.get("external"))
    m.scene_ops = args.scene or bool(replay and replay.get("scene"))
    m.sources = args.sources or bool(replay and replay.get("sources"))
    m.renames = args.renames or bool(replay and replay.get("renames"))
    m.obstacles = args.obstacles or bool(replay and replay.get("obstacles"))
    record = {"seed": args.seed, "effects": effects, "delete_baked": m.delete_baked,
              "more": m.more, "elsewhere": m.elsewhere, "moves": m.moves,
              "relations": m.relations, "external": m.external, "scene": m.scene_ops,
              "sources": m.sources, "renames": m.renames, "obstacles": m.obstacles,
              "actions": m.log}
    m.record = record
    status = "OK"
    try:
        m.start()
        if replay is not None:
            actions = replay["actions"][:replay.get("main_steps", len(replay["actions"]))]
            for k, a in enumerate(actions):
                if a["op"] == "render" and args.no_render:
                    continue
                m.step(a, k)
            record["main_steps"] = len(m.log)
            if replay.get("finish", True):
                m.finish(render=not args.no_render)
        else:
            k = 0
            while k < args.steps:
                for a in m.choose():
                    m.step(a, k)
                    k += 1
            record["main_steps"] = len(m.log)
            m.finish(render=not args.no_render)
    except Violation as v:
        status = "FAIL"
        record["violation"] = {"kind": v.kind, "detail": v.detail, "step": len(m.log)}
        print(f"MONKEY FAIL seed={args.seed} step={len(m.log)} kind={v.kind}\n{v.detail}",
              flush=True)
    with open(os.path.join(tmp, "actions.json"), "w") as f:
        json.dump(record, f, indent=1)
    if status == "OK":
        print(f"MONKEY OK seed={args.seed} steps={len(m.log)} effects={','.join(effects)}",
              flush=True)
    sys.stdout.flush()
    # Leave Blender at once: a bake's thread must never outlive the check.
    os._exit(0 if status == "OK" else 1)


main()
