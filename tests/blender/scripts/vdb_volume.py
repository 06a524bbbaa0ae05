"""A VDB written by hydrobake.core.vdb loads in Blender as a Volume object with its grids."""
import os

import bpy
import numpy as np

import in_blender

in_blender.enable()
from hydrobake.core import vdb  # noqa: E402
from hydrobake.blender.bridge import volumes  # noqa: E402

tmp = in_blender.args()[0]
dens = np.zeros((16, 16, 16), np.float32)
dens[4:12, 4:12, 4:12] = 1.0
vel = np.zeros((16, 16, 16, 3), np.float32)
vel[..., 2] = 2.0
uvw = np.random.default_rng(0).random((16, 16, 16, 3)).astype(np.float32)
for frame in (1, 2):
    vdb.write(os.path.join(tmp, f"fluid_{frame:04d}.vdb"), [
        dict(name="density", array=dens, voxel_size=0.05),
        dict(name="velocity", array=vel, voxel_size=0.05, vector_type="CONTRAVARIANT_RELATIVE"),
        dict(name="uvw", array=uvw, voxel_size=0.05, vector_type="INVARIANT")])
obj = volumes.load_volume_sequence(tmp, "fluid", 1, 2, "HBK_Fluid")
assert obj.type == "VOLUME"
bpy.context.scene.frame_set(1)
grids = volumes.grid_names(obj)
assert grids == {"density": "FLOAT", "velocity": "VECTOR_FLOAT", "uvw": "VECTOR_FLOAT"}, grids
assert obj.data.is_sequence and obj.data.frame_duration == 2
bpy.context.scene.frame_set(2)
assert volumes.grid_names(obj) == grids
# The density's world extent follows the voxel size: 16 voxels of 5 cm.
depsgraph = bpy.context.evaluated_depsgraph_get()
bb = [obj.matrix_world @ __import__("mathutils").Vector(c) for c in
      obj.evaluated_get(depsgraph).bound_box]
size = max(c.x for c in bb) - min(c.x for c in bb)
assert 0.35 <= size <= 0.85, size
print("VDB VOLUME OK", grids)
