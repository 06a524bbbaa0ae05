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


def evaluated_object(obj, depsgraph, role=None):
    """``obj`` as ``depsgraph`` evaluated it: its modifiers, shape keys, particles and motion.

    Blender evaluates these for certain only for an object its view layer enables: Show in
    Viewports on, and in some collection of the layer that is neither excluded nor disabled in
    viewports (its eye, hidden, is fine). Any other object may come back as the original, or
    as a copy without its modifiers or stuck at an old frame (measured: a Bevel box read as 6
    faces, not 26), depending on what was evaluated before; a bake would silently take the
    wrong shape, so it is refused by name instead."""
    ev = obj.evaluated_get(depsgraph)
    if ev.is_evaluated and enabled(depsgraph.view_layer, obj):
        return ev
    who = f"{role}: {obj.name!r}" if role else obj.name
    raise ValueError(f"{who} is not evaluated in view layer {depsgraph.view_layer.name!r} "
                     "(Show in Viewports is off, or none of its collections is in the scene, "
                     "included and enabled in viewports), so the bake would miss its modifiers, "
                     "particles and motion; turn on Object Properties > Visibility > Show In > Viewports "
                     "and include one of its collections, then bake")


def enabled(view_layer, obj):
    """Whether ``view_layer`` enables ``obj`` in viewports, as Blender's layer sync does: Show
    in Viewports on, and a path of layer collections to one holding it that none excludes or
    disables (Collection.hide_viewport)."""
    if obj.hide_viewport:
        return False
    holders = set(obj.users_collection)

    def reaches(lc):
        if lc.exclude or lc.collection.hide_viewport:
            return False
        return lc.collection in holders or any(reaches(c) for c in lc.children)
    return reaches(view_layer.layer_collection)
