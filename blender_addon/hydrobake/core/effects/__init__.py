"""The registry of effects: name -> Effect subclass. Effect modules register on import."""
import importlib

EFFECTS = {}
_MODULES = ("caustics",)  # effect modules shipped with the addon, loaded on first use


def register(cls):
    """Class decorator: makes an Effect subclass available by its ``name``."""
    if not cls.name:
        raise ValueError(f"{cls.__name__}: an effect needs a name")
    EFFECTS[cls.name] = cls
    return cls


def load_all():
    """Imports every shipped effect module whose kernel this library has."""
    for mod in _MODULES:
        try:
            importlib.import_module(f"{__name__}.{mod}")
        except ModuleNotFoundError as exc:
            if exc.name != f"{__name__}.{mod}":
                raise
    return dict(EFFECTS)


def get(name):
    load_all()
    try:
        return EFFECTS[name]
    except KeyError:
        raise KeyError(f"effect {name!r}: known effects are {', '.join(sorted(EFFECTS))}") from None
