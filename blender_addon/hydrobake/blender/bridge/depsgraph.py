"""The evaluated dependency graph, got without Blender's context lookups.

context.evaluated_depsgraph_get() lets Python's lock go while it evaluates, and then looks
the scene and view layer up through the context; under a context override (a script that
invoked a bake inside temp_override) that lookup reads a Python dict, and Blender 3.4 takes
the lock for it only if no thread holds it (BPY_context_member_get): while another bake's
thread held it, the two threads' allocations could crash Blender. Here the view layer is
read while the lock is held and its graph evaluated with no context at all."""
import bpy


def evaluated(context=None):
    """The context's view layer's dependency graph, evaluated (what
    context.evaluated_depsgraph_get() returns)."""
    context = context or bpy.context
    depsgraph = context.view_layer.depsgraph
    if depsgraph is None:  # never evaluated yet: made by the context's own call
        return context.evaluated_depsgraph_get()
    depsgraph.update()
    return depsgraph
