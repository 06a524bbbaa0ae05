"""A Blender 3.4.1 bug, not the addon's: Mantaflow is not safe with several liquid domains. A
baked liquid domain with three Shift+D copies (one cache folder) plays its frames, and
Blender segfaults as it quits (4 runs of 4; with one copy, 1 of 3). In a monkey run (every
flag + --sources 2) Mantaflow also aborted in a view layer update while two domains' scripts
ran at once ("can't clean grid cache, some grids are still in use"); its replay did not. The
monkey does not copy liquid domains.

    blender -b --factory-startup --python mantaflow_domain_copies.py

prints "played" and then segfaults (exit 139).
"""
import tempfile

import bpy

for o in list(bpy.data.objects):
    bpy.data.objects.remove(o)
scene = bpy.context.scene
scene.frame_start, scene.frame_end = 1, 3
bpy.ops.mesh.primitive_cube_add(size=2)
tank = bpy.context.active_object
d = tank.modifiers.new("Fluid", "FLUID")
d.fluid_type = "DOMAIN"
d = d.domain_settings
d.domain_type, d.resolution_max, d.use_mesh, d.cache_type = "LIQUID", 16, True, "ALL"
d.cache_directory = tempfile.mkdtemp()
d.cache_frame_start, d.cache_frame_end = 1, 3
bpy.ops.mesh.primitive_uv_sphere_add(radius=0.4, location=(0, 0, 0.3))
ball = bpy.context.active_object
f = ball.modifiers.new("Fluid", "FLUID")
f.fluid_type = "FLOW"
f.flow_settings.flow_type, f.flow_settings.flow_behavior = "LIQUID", "GEOMETRY"
with bpy.context.temp_override(object=tank, active_object=tank, scene=scene):
    assert bpy.ops.fluid.bake_all() == {"FINISHED"}
for _ in range(3):
    for o in bpy.context.view_layer.objects:
        o.select_set(o == tank)
    bpy.context.view_layer.objects.active = tank
    assert bpy.ops.object.duplicate() == {"FINISHED"}
copies = [o for o in bpy.data.objects if o.name.startswith("Cube.")]
for k in range(300):  # played back, a copy moved now and then
    scene.frame_set(1 + k % 3)
    copies[k % 3].location.x += 0.001
    bpy.context.view_layer.update()
print("played", [o.name for o in bpy.data.objects], flush=True)
