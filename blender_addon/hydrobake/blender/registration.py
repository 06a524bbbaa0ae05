"""Registers the addon's classes and the per-effect settings on objects."""
import bpy

from . import effects, operators, properties, ui

_registered = []
_object_props = []


def register():
    classes = [properties.HydrobakeSceneSettings, *operators.CLASSES]
    for name, beffect in effects.load_all().items():
        classes.append(properties.make_settings_class(name, beffect.core_class().spec))
        classes.append(ui.make_panel(beffect))
    for cls in classes:
        bpy.utils.register_class(cls)
        _registered.append(cls)
    bpy.types.Scene.hydrobake = bpy.props.PointerProperty(type=properties.HydrobakeSceneSettings)
    for cls in classes:
        if cls.__name__.startswith("HYDROBAKE_PG_"):
            attr = "hydrobake_" + cls.__name__[len("HYDROBAKE_PG_"):]
            setattr(bpy.types.Object, attr, bpy.props.PointerProperty(type=cls))
            _object_props.append(attr)


def unregister():
    from . import jobs
    for job in list(jobs.ACTIVE.values()):
        job.runner.cancel()
        job.runner.join(5.0)
    jobs.ACTIVE.clear()
    for attr in _object_props:
        delattr(bpy.types.Object, attr)
    _object_props.clear()
    del bpy.types.Scene.hydrobake
    for cls in reversed(_registered):
        bpy.utils.unregister_class(cls)
    _registered.clear()
