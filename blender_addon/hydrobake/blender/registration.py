"""Registers the addon's classes and the per-effect settings on objects."""
import bpy

from . import effects, operators, properties, ui

_registered = []
_object_props = []


@bpy.app.handlers.persistent
def _cancel_on_load(*_args):
    """Loading another file ends modal operators; stop their bakes too (frames kept)."""
    from . import jobs
    jobs.cancel_all()


@bpy.app.handlers.persistent
def _refresh_on_load(*_args):
    """The objects' addresses are new in an opened file: tell bakes their holders again. The
    bakes' images and volumes are found again where a Save As left their paths behind, and
    materials a Free would tidy are tidied (materials.tidy_on_load), and materials made for
    deleted objects' bakes that nothing records any more go (forget_dropped_made)."""
    from . import jobs, paths
    from .bridge import materials
    jobs.refresh_holders()
    paths.repoint_data()
    materials.tidy_on_load()
    for beffect in effects.BLENDER_EFFECTS.values():
        beffect.forget_dropped_made()


@bpy.app.handlers.persistent
def _after_save(*_args):
    """A file saved into another folder records its bakes from there; the saved file records
    renamed objects' new bakes: their old ones can go."""
    from . import jobs, paths
    paths.after_save()
    jobs.free_superseded()


_objects_seen = [0]


@bpy.app.handlers.persistent
def _after_deletes(*_args):
    """After an update that left fewer objects (a delete): the mesh slots a made material
    left, kept for a deleted object, go; and each effect's leftovers of deleted bakes.
    Counting is all the other updates cost."""
    count = len(bpy.data.objects)
    fewer, _objects_seen[0] = count < _objects_seen[0], count
    if fewer:
        from .bridge import materials
        materials.drop_left_empty_slots()
        for beffect in effects.BLENDER_EFFECTS.values():
            beffect.after_deletes()


@bpy.app.handlers.persistent
def _rebase_before_save(*_args):
    """The file about to be saved records its bakes relative to where it is now."""
    from . import paths
    paths.before_save()


def register():
    classes, settings = [properties.HydrobakeSceneSettings, *operators.CLASSES], {}
    for name, beffect in effects.load_all().items():
        classes.extend(beffect.extra_classes())
        pgs = properties.make_settings_classes(name, beffect.core_class().groups(),
                                               beffect.extra_properties())
        classes.extend(pgs)
        settings[name] = pgs[-1]  # the effect's own group comes last, after its parts
        classes.append(ui.make_panel(beffect))
    for cls in classes:
        bpy.utils.register_class(cls)
        _registered.append(cls)
    bpy.types.Scene.hydrobake = bpy.props.PointerProperty(type=properties.HydrobakeSceneSettings)
    for name, cls in settings.items():
        setattr(bpy.types.Object, f"hydrobake_{name}", bpy.props.PointerProperty(type=cls))
        _object_props.append(f"hydrobake_{name}")
        effects.BLENDER_EFFECTS[name].register_extra()
    bpy.types.TOPBAR_MT_file_cleanup.append(operators.draw_cleanup_menu)
    bpy.app.handlers.load_pre.append(_cancel_on_load)
    bpy.app.handlers.load_post.append(_refresh_on_load)
    bpy.app.handlers.save_pre.append(_rebase_before_save)
    bpy.app.handlers.save_post.append(_after_save)
    bpy.app.handlers.depsgraph_update_post.append(_after_deletes)


def unregister():
    from . import jobs
    jobs.cancel_all()
    bpy.types.TOPBAR_MT_file_cleanup.remove(operators.draw_cleanup_menu)
    if _cancel_on_load in bpy.app.handlers.load_pre:
        bpy.app.handlers.load_pre.remove(_cancel_on_load)
    if _refresh_on_load in bpy.app.handlers.load_post:
        bpy.app.handlers.load_post.remove(_refresh_on_load)
    if _rebase_before_save in bpy.app.handlers.save_pre:
        bpy.app.handlers.save_pre.remove(_rebase_before_save)
    if _after_save in bpy.app.handlers.save_post:
        bpy.app.handlers.save_post.remove(_after_save)
    if _after_deletes in bpy.app.handlers.depsgraph_update_post:
        bpy.app.handlers.depsgraph_update_post.remove(_after_deletes)
    for attr in _object_props:
        delattr(bpy.types.Object, attr)
        effects.BLENDER_EFFECTS[attr[len("hydrobake_"):]].unregister_extra()
    _object_props.clear()
    del bpy.types.Scene.hydrobake
    for cls in reversed(_registered):
        bpy.utils.unregister_class(cls)
    _registered.clear()
