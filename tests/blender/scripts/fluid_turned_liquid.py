"""A Mantaflow liquid domain turned a quarter about z (and scaled): Mantaflow simulates along
the domain's own axes, so a ball thrown along the domain's x flies along the world's +y. The
fluid textures' velocity must be the world's: along +y where the liquid is, at the speed its
mesh moves."""
import os

import bpy
import numpy as np

import in_blender

in_blender.enable()
from hydrobake.core import vdb  # noqa: E402
from hydrobake.core.bake.cache import frame_path  # noqa: E402

tmp = in_blender.args()[0]
bpy.ops.wm.save_as_mainfile(filepath=os.path.join(tmp, "turned.blend"))
scene = bpy.context.scene
scene.frame_start, scene.frame_end = 1, 5
scene.render.fps = 24
dom, d, flow = in_blender.liquid((3, 0, 1), 20, "//manta", 0.3, (3, 0, 1.3))
dom.rotation_euler = (0.0, 0.0, np.pi / 2)  # the domain's x is the world's +y
dom.scale = (1.0, 0.5, 1.0)
flow.use_initial_velocity = True
flow.velocity_coord = (2.0, 0.0, 0.0)  # Mantaflow's (the domain's) axes
in_blender.bake_liquid(dom)


def liquid_centre(frame):
    scene.frame_set(frame)
    ev = dom.evaluated_get(bpy.context.evaluated_depsgraph_get())
    me = ev.to_mesh()
    pts = np.array([tuple(dom.matrix_world @ v.co) for v in me.vertices])
    ev.to_mesh_clear()
    return (pts.min(axis=0) + pts.max(axis=0)) / 2


drift = (liquid_centre(5) - liquid_centre(3)) * 24 / 2  # m/s of the liquid's mesh
assert drift[1] > 1.0 and abs(drift[0]) < 0.3, drift  # Mantaflow moves it along world +y

s = dom.hydrobake_fluid
s.enabled = True
s.fluid.source = "VELOCITY_GRID"
s.fluid.resolution = (8, 16, 16)
s.fluid.textures = 2
s.use_scene_range, s.frame_start, s.frame_end = False, 1, 5
assert bpy.ops.hydrobake.bake(effect="fluid", object_name="Tank") == {"FINISHED"}
for f in (3, 5):
    path = frame_path(s.bake_folder, "fluid", f, "vdb")
    v = vdb.read_grid(path, "velocity")
    dens = vdb.read_grid(path, "density")
    wet = np.zeros(v.shape[:3], bool)
    n = [min(a, b) for a, b in zip(v.shape, dens.shape)]
    wet[:n[0], :n[1], :n[2]] = dens[:n[0], :n[1], :n[2]] > 0
    mean = v[wet].mean(axis=0)
    # Along the world's +y as the liquid flies, not along x (the domain's own axis).
    assert abs(mean[1] - drift[1]) < 0.35 * drift[1] and abs(mean[0]) < 0.2, (f, mean, drift)
    # Free fall along z, g t, in world metres (the domain's scale is not mixed into it).
    assert abs(mean[2] + 9.81 * f / 24) < 0.25 * 9.81 * f / 24, (f, mean)
print("FLUID TURNED LIQUID OK", drift.round(2))
