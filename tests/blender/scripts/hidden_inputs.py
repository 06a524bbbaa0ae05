"""An object a bake reads whose view layer leaves it out (Show in Viewports off, its only
collection excluded or disabled in viewports) is not evaluated by Blender: its modifiers and
particles are missing. Such a bake is refused by name and setting, before anything is
written, and the panel names the object beforehand; an object hidden by its eye is evaluated
and bakes. What was measured before the refusal: a Subdivision plane read with 2 triangles
instead of 32, a hidden emitter's particles missing."""
import os

import bpy

import in_blender

in_blender.enable()
from hydrobake.blender.bridge import mesh_data  # noqa: E402

tmp = in_blender.empty_file("hidden.blend")
LEFT_OUT = "is not evaluated in view layer 'ViewLayer'"
HOW = "Object Properties > Visibility > Show In > Viewports"


def refused(effect, name):
    """The Bake button's error for ``name`` (it must fail, and leave no bake behind)."""
    settings = getattr(bpy.data.objects[name], f"hydrobake_{effect}")
    try:
        bpy.ops.hydrobake.bake(effect=effect, object_name=name)
    except RuntimeError as exc:
        assert not settings.is_baked, (effect, name)
        folder = bpy.path.abspath(settings.bake_folder) if settings.bake_folder else ""
        assert not folder or not os.path.isdir(folder) or not os.listdir(folder), folder
        print(f"{effect} {name}: {exc}")
        return str(exc)
    raise AssertionError(f"{effect} {name}: baked")


def panel_says(effect, name):
    """The panel's line naming what the view layer leaves out, or None."""
    said = [k.get("text") for n, a, k in in_blender.panel_calls(bpy.data.objects[name], effect)
            if n == "label" and str(k.get("text", "")).startswith("Not evaluated")]
    return said[0] if said else None


def hidden_collection(name, *objs):
    """A collection of its own in the scene holding ``objs`` (and nothing else of theirs)."""
    coll = bpy.data.collections.new(name)
    bpy.context.scene.collection.children.link(coll)
    for o in objs:
        for c in list(o.users_collection):
            c.objects.unlink(o)
        coll.objects.link(o)
    return coll, bpy.context.view_layer.layer_collection.children[name]


# Rain: the glass itself, Show in Viewports off; its eye closed is fine.
glass = in_blender.uv_plane("Glass")
glass.modifiers.new("Subdivision", "SUBSURF").levels = 2
r = glass.hydrobake_rain
r.enabled, r.use_scene_range, r.frame_start, r.frame_end = True, False, 1, 1
r.rain.cell_size = 0.05
assert len(mesh_data.triangles(glass)[1]) == 32
glass.hide_viewport = True
assert panel_says("rain", "Glass") == "Not evaluated in this view layer: Glass"
msg = refused("rain", "Glass")
assert f"Glass rain: Glass {LEFT_OUT}" in msg and HOW in msg, msg
glass.hide_viewport = False
glass.hide_set(True)
assert panel_says("rain", "Glass") is None
assert len(mesh_data.triangles(glass)[1]) == 32
assert bpy.ops.hydrobake.bake(effect="rain", object_name="Glass") == {"FINISHED"}
assert r.is_baked
glass.hide_set(False)

# Snow: a collider in a collection excluded from the view layer.
snowy = in_blender.uv_plane("Snowy")
snowy.location.x = 4.0
post = in_blender.new_box("Post", (0.2, 0.2, 1.0), (4.0, 0.0, 0.5))
post.modifiers.new("Bevel", "BEVEL")
posts, posts_layer = hidden_collection("Posts", post)
s = in_blender.snow(snowy, (1, 1), 10.0, 16)
s.colliders = posts
posts_layer.exclude = True
assert panel_says("snow", "Snowy") == "Not evaluated in this view layer: Colliders: Post"
msg = refused("snow", "Snowy")
assert f"Snowy snow: Colliders: 'Post' {LEFT_OUT}" in msg and HOW in msg, msg
posts_layer.exclude = False
posts_layer.hide_viewport = True  # the collection's eye: still evaluated
assert bpy.ops.hydrobake.bake(effect="snow", object_name="Snowy") == {"FINISHED"}
posts_layer.hide_viewport = False

# Caustics: the ground in a collection disabled in viewports, then a hidden disturber.
water = in_blender.new_plane("Water")
water.location = (0.0, 8.0, 0.0)
floor = in_blender.new_plane("Floor")
floor.location, floor.scale = (0.0, 8.0, -0.5), (1.5, 1.5, 1.0)
c = water.hydrobake_caustics
c.enabled, c.ground_object = True, floor
c.use_scene_range, c.frame_start, c.frame_end = False, 1, 2
c.water.width, c.map_resolution = 16, 32
floors, _ = hidden_collection("Floors", floor)
floors.hide_viewport = True
assert panel_says("caustics", "Water") == "Not evaluated in this view layer: Ground: Floor"
msg = refused("caustics", "Water")
assert f"Water caustics: Ground: 'Floor' {LEFT_OUT}" in msg and HOW in msg, msg
floors.hide_viewport = False
paddle = in_blender.new_box("Paddle", (0.2, 0.2, 0.6), (0.0, 8.0, 0.0))
c.disturber_object = paddle
paddle.hide_viewport = True
msg = refused("caustics", "Water")
assert f"Disturber: 'Paddle' {LEFT_OUT}" in msg, msg
paddle.hide_viewport = False
assert bpy.ops.hydrobake.bake(effect="caustics", object_name="Water") == {"FINISHED"}

# Fluid: the emitter of the particles, Show in Viewports off.
domain = in_blender.new_box("Domain", (1.0, 0.5, 0.5), (0.5, -6.0, 0.25))
emitter = in_blender.new_box("Emitter", (0.3, 0.3, 0.05), (0.5, -6.0, 0.4))
ps = emitter.modifiers.new("Drops", "PARTICLE_SYSTEM").particle_system.settings
ps.count, ps.frame_start, ps.frame_end, ps.lifetime = 200, 1, 1, 100
f = domain.hydrobake_fluid
f.enabled, f.particle_object = True, emitter
f.fluid.source = "PARTICLES"
f.fluid.resolution, f.fluid.substeps, f.fluid.textures = (16, 8, 8), 4, 2
f.use_scene_range, f.frame_start, f.frame_end = False, 1, 2
emitter.hide_viewport = True
assert panel_says("fluid", "Domain") == "Not evaluated in this view layer: Particles: Emitter"
msg = refused("fluid", "Domain")
assert f"Particles: 'Emitter' {LEFT_OUT}" in msg, msg
emitter.hide_viewport = False
assert panel_says("fluid", "Domain") is None
assert bpy.ops.hydrobake.bake(effect="fluid", object_name="Domain") == {"FINISHED"}
print("HIDDEN INPUTS OK")
