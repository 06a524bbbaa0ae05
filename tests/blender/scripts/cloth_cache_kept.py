"""Pressing Bake leaves the scene's simulation caches alone: a cloth played through ten frames
keeps its ten cached frames, not marked outdated (a bake that tagged every object's transform
to read the scene afresh made the cloth's cache outdated, and its next frame cut it short)."""
import bpy

import in_blender

in_blender.enable()
from hydrobake.blender import jobs  # noqa: E402

in_blender.empty_file("cloth.blend")
scene = bpy.context.scene
bpy.ops.mesh.primitive_plane_add(size=2.0, location=(3.0, 0.0, 1.0))
sheet = bpy.context.active_object
sheet.modifiers.new("Cloth", "CLOTH")
cache = sheet.modifiers["Cloth"].point_cache
for f in range(1, 11):
    scene.frame_set(f)
before = cache.info
assert before.startswith("10 frames in memory") and "outdated" not in before, before

cube = in_blender.new_box("Cube", (1.0, 1.0, 1.0), (0.0, 0.0, 0.0))
cube.data.uv_layers.new(name="UVMap")
in_blender.snow(cube, (1, 3), 20, 32)
job = jobs.Job(bpy.context, cube, "snow")
job.runner.effect.close()
assert cache.info == before, (cache.info, before)
scene.frame_set(5)
assert cache.info == before, (cache.info, before)
print("CLOTH CACHE KEPT OK", before)
