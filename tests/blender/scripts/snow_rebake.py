"""A second Bake (and a Resume) of snow on the default cube rewires the same nodes: the snow Mix
Shader takes the material's own surface shader, never itself, and Free Bake leaves the
material as it was (its Principled BSDF into the output). A re-bake with Displacement turned
off takes the depth out of the material: the surface no longer moves."""
import os

import bpy

import in_blender

in_blender.enable()

tmp = in_blender.args()[0]
bpy.ops.wm.save_as_mainfile(filepath=os.path.join(tmp, "rebake.blend"))
cube = bpy.data.objects["Cube"]
s = in_blender.snow(cube, (1, 2), 20, 64)
tree = bpy.data.materials["Material"].node_tree


def links():
    return sorted(f"{l.from_node.name} -> {l.to_node.name}.{l.to_socket.identifier}"
                  for l in tree.links if l.from_node.type in ("BSDF_PRINCIPLED", "MIX_SHADER"))


assert bpy.ops.hydrobake.bake(effect="snow", object_name="Cube") == {"FINISHED"}
first = links()
assert bpy.ops.hydrobake.bake(effect="snow", object_name="Cube") == {"FINISHED"}
assert links() == first, (first, links())
assert bpy.ops.hydrobake.bake(effect="snow", object_name="Cube", resume=True) == {"FINISHED"}
assert links() == first, (first, links())
mix = next(n for n in tree.nodes if n.get("hydrobake") == "snow.mix")
assert mix.inputs[1].links[0].from_node.type == "BSDF_PRINCIPLED", first
assert not any(l.from_node == mix for l in mix.inputs[1].links), first
out = next(n for n in tree.nodes if n.type == "OUTPUT_MATERIAL")
assert s.use_displacement and out.inputs["Displacement"].is_linked
s.use_displacement = False
assert bpy.ops.hydrobake.bake(effect="snow", object_name="Cube") == {"FINISHED"}
assert links() == first, (first, links())
roles = sorted(n["hydrobake"] for n in tree.nodes if n.get("hydrobake"))
assert not out.inputs["Displacement"].is_linked and \
    not {"snow.depth", "snow.displacement"} & set(roles), roles
assert bpy.ops.hydrobake.free_bake(effect="snow", object_name="Cube") == {"FINISHED"}
assert links() == ["Principled BSDF -> Material Output.Surface"], links()
assert not any(n.get("hydrobake") for n in tree.nodes)
print("SNOW REBAKE OK")
