"""Blender halves of the effects: what each takes from the scene and how its bake is wired
back into materials and objects. Each module defines one BlenderEffect subclass."""
from ...core import effects as core_effects

_MODULES = ("caustics", "snow", "rain", "fluid")
BLENDER_EFFECTS = {}


def register_effect(cls):
    BLENDER_EFFECTS[cls.name] = cls
    return cls


def load_all():
    """The Blender effects whose core effect exists in this build."""
    core_effects.load_all()
    core_effects.import_present(__name__, _MODULES)
    return {n: c for n, c in BLENDER_EFFECTS.items() if n in core_effects.EFFECTS}


def get(name):
    effects = load_all()
    if name not in effects:
        raise KeyError(f"effect {name!r}: known effects are {', '.join(sorted(effects)) or 'none'}")
    return effects[name]
