"""Small helpers for wiring baked maps into node materials non-destructively: every node
Hydrobake adds is labelled, so it can be found again and removed by Free Bake."""
import bpy

TAG = "hydrobake"


def ensure_material(obj, name):
    """The object's first material, or a new node material ``name`` assigned to it."""
    if obj.data.materials and obj.data.materials[0] is not None:
        mat = obj.data.materials[0]
    else:
        mat = bpy.data.materials.get(name) or bpy.data.materials.new(name)
        obj.data.materials.append(mat)
    mat.use_nodes = True
    return mat


def tagged(node_tree, role):
    """Hydrobake's node with ``role`` in this tree, or None."""
    for node in node_tree.nodes:
        if node.get(TAG) == role:
            return node
    return None


def add_node(node_tree, bl_idname, role, location=(0, 0), label=None):
    """Adds (or reuses) a node tagged with ``role``."""
    node = tagged(node_tree, role)
    if node is None or node.bl_idname != bl_idname:
        if node is not None:
            node_tree.nodes.remove(node)
        node = node_tree.nodes.new(bl_idname)
        node[TAG] = role
    node.location = location
    node.label = label or f"Hydrobake {role}"
    return node


def remove_tagged(node_tree, prefix=""):
    """Removes every Hydrobake node whose role starts with ``prefix``; returns the count."""
    gone = [n for n in node_tree.nodes if isinstance(n.get(TAG), str) and
            n[TAG].startswith(prefix)]
    for n in gone:
        node_tree.nodes.remove(n)
    return len(gone)


def principled(node_tree):
    return next((n for n in node_tree.nodes if n.type == "BSDF_PRINCIPLED"), None)
