"""Built-in sample textures made tileable. The method needs solid textures that repeat every uvw
unit (the fields wrap at 1 -> 0, paper section 3), and Blender's noise, wave and voronoi do not.
A node group evaluates the texture at frac(uvw) - c for the eight corners c of the unit cube and
blends them with weights that are 1 for c = 0 away from the tile's faces and move to the copy
one tile back within `BAND` of each face: at frac = 1 that copy reads the same point as frac = 0
does, so the result repeats exactly. Inside the tile, away from the band, it is the plain
texture."""
import bpy

BAND = 0.3  # of a tile, at each face where copies are blended (less: sharper blend seams)
VERSION = 1  # bumped when the group's nodes change, so old files get the new group

KINDS = {
    "noise": ("ShaderNodeTexNoise", {"Scale": 3.0, "Detail": 6.0}),
    "wave": ("ShaderNodeTexWave", {"Scale": 2.0, "Distortion": 4.0}),
    "voronoi": ("ShaderNodeTexVoronoi", {"Scale": 6.0}),
}


def group(kind):
    """The tileable node group for a built-in ``kind`` (Vector in, Color out), made once."""
    name = f"HBK Tileable {kind.title()}"
    tree = bpy.data.node_groups.get(name)
    if tree is not None and tree.get("hydrobake_version") == VERSION:
        return tree
    if tree is None:
        tree = bpy.data.node_groups.new(name, "ShaderNodeTree")
    tree.nodes.clear()
    tree.inputs.clear()
    tree.outputs.clear()
    tree.inputs.new("NodeSocketVector", "Vector")
    tree.outputs.new("NodeSocketColor", "Color")
    tree["hydrobake_version"] = VERSION
    nodes, links = tree.nodes, tree.links

    def add(idname, x, y, op=None, **inputs):
        n = nodes.new(idname)
        n.location = (x, y)
        if op:
            n.operation = op
        for key, value in inputs.items():
            n.inputs[key].default_value = value
        return n

    gin = add("NodeGroupInput", -1400, 0)
    gout = add("NodeGroupOutput", 1000, 0)
    frac = add("ShaderNodeVectorMath", -1200, 0, "FRACTION")
    links.new(gin.outputs["Vector"], frac.inputs[0])
    sep = add("ShaderNodeSeparateXYZ", -1000, 300)
    links.new(frac.outputs["Vector"], sep.inputs[0])
    # Per axis: t = smoothstep(1 - BAND, 1, f) is the weight of the copy one tile back.
    weight = []
    for a, axis in enumerate("XYZ"):
        t = add("ShaderNodeMapRange", -800, 500 - 250 * a)
        t.interpolation_type = "SMOOTHSTEP"
        t.inputs["From Min"].default_value = 1.0 - BAND
        t.inputs["From Max"].default_value = 1.0
        links.new(sep.outputs[axis], t.inputs["Value"])
        keep = add("ShaderNodeMath", -600, 500 - 250 * a, "SUBTRACT")
        keep.inputs[0].default_value = 1.0
        links.new(t.outputs["Result"], keep.inputs[1])
        weight.append((keep.outputs["Value"], t.outputs["Result"]))  # (copy 0, copy 1)
    idname, settings = KINDS[kind]
    total = None
    for c in range(8):
        bits = (c & 1, c >> 1 & 1, c >> 2 & 1)
        y = 900 - 260 * c
        shift = add("ShaderNodeVectorMath", -400, y, "SUBTRACT")
        shift.inputs[1].default_value = tuple(float(b) for b in bits)
        links.new(frac.outputs["Vector"], shift.inputs[0])
        tex = add(idname, -200, y, **settings)
        links.new(shift.outputs["Vector"], tex.inputs["Vector"])
        wxy = add("ShaderNodeMath", 0, y + 80, "MULTIPLY")
        links.new(weight[0][bits[0]], wxy.inputs[0])
        links.new(weight[1][bits[1]], wxy.inputs[1])
        w = add("ShaderNodeMath", 150, y + 80, "MULTIPLY")
        links.new(wxy.outputs["Value"], w.inputs[0])
        links.new(weight[2][bits[2]], w.inputs[1])
        part = add("ShaderNodeVectorMath", 300, y, "SCALE")
        links.new(tex.outputs["Color"], part.inputs[0])
        links.new(w.outputs["Value"], part.inputs["Scale"])
        if total is None:
            total = part.outputs["Vector"]
        else:
            s = add("ShaderNodeVectorMath", 500, y, "ADD")
            links.new(total, s.inputs[0])
            links.new(part.outputs["Vector"], s.inputs[1])
            total = s.outputs["Vector"]
    links.new(total, gout.inputs["Color"])
    return tree
