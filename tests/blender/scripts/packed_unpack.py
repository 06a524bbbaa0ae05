"""File > External Data > Pack Resources, then Unpack Resources into the current folder (Blender
writes each packed image to //textures/<its file name> and each volume to //volumes/...):
two objects' bakes of one effect keep two files, each unpacked image and volume showing its
own bake. With one file name for every bake (coverage_0001.exr), the second object took the
first's file (Use Local) or wrote over it (Write Local), and showed the first's snow (monkey
every flag + --scene --external 933). One-frame bakes, since Blender packs no sequences."""
import os

import bpy

import in_blender

in_blender.enable()
tmp = in_blender.empty_file("unpack.blend")
bakes = []
for i, name in enumerate(("Snowy A", "Snowy B")):
    plane = in_blender.uv_plane(name)
    plane.location.x = 3.0 * i
    in_blender.snow(plane, (1, 1), 40.0, 16 + 8 * i)  # two sizes: never the same bytes
    bakes.append((name, "snow"))
for i in range(2):
    domain, fill, _fluid = in_blender.dam_break((24 + 4 * i, 12, 12), textures=2, frames=(1, 1))
    domain.location.y += 3.0 * i
    fill.location.y += 3.0 * i
    bakes.append((domain.name, "fluid"))
for name, effect in bakes:
    assert bpy.ops.hydrobake.bake(effect=effect, object_name=name) == {"FINISHED"}, name
bpy.ops.wm.save_mainfile()


def blocks():
    return [b for b in (*bpy.data.images, *bpy.data.volumes)
            if b.name.startswith("HBK") and b.users and b.filepath]


def unpacked(method):
    """Packs every bake's images and volumes, unpacks them with ``method``, and checks that
    each reads a file of its own holding what it had packed."""
    assert bpy.ops.file.pack_all() == {"FINISHED"}
    packed = {b.name: b.packed_file.data for b in blocks() if b.packed_file is not None}
    kinds = sorted(type(b).__name__ for b in blocks() if b.name in packed)
    assert kinds == ["Image"] * 4 + ["Volume"] * 2, kinds  # coverage and depth, two volumes
    assert bpy.ops.file.unpack_all(method=method) == {"FINISHED"}
    paths = {}
    for b in blocks():
        if b.name not in packed:
            continue
        assert b.packed_file is None, (method, b.name)
        path = os.path.realpath(bpy.path.abspath(b.filepath))
        assert path.startswith(os.path.realpath(tmp) + os.sep) and \
            os.path.basename(os.path.dirname(path)) in ("textures", "volumes"), (b.name, path)
        assert path not in paths, f"{method}: {b.name} reads {paths.get(path)}'s {b.filepath}"
        paths[path] = b.name
        with open(path, "rb") as f:
            assert f.read() == packed[b.name], f"{method}: {b.name} shows another bake"
    return sorted(bpy.path.basename(p) for p in paths)


names = unpacked("USE_LOCAL")
assert unpacked("WRITE_LOCAL") == names
print("unpacked:", names)
print("PACKED UNPACK OK")
