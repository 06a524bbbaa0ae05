"""The registry of effects: name -> Effect subclass. Effect modules register on import."""
import importlib

EFFECTS = {}
_MODULES = ("caustics", "snow", "rain", "fluid")  # effect modules shipped with the addon


def register(cls):
    """Class decorator: makes an Effect subclass available by its ``name``."""
    if not cls.name:
        raise ValueError(f"{cls.__name__}: an effect needs a name")
    EFFECTS[cls.name] = cls
    return cls


def import_present(package, modules):
    """Imports ``package.<m>`` for each m that exists; an error inside a module propagates."""
    for mod in modules:
        try:
            importlib.import_module(f"{package}.{mod}")
        except ModuleNotFoundError as exc:
            if exc.name != f"{package}.{mod}":
                raise


def load_all():
    """Imports every shipped effect module."""
    import_present(__name__, _MODULES)
    return dict(EFFECTS)


def get(name):
    load_all()
    try:
        return EFFECTS[name]
    except KeyError:
        raise KeyError(f"effect {name!r}: known effects are {', '.join(sorted(EFFECTS))}") from None
