"""hydrobake.core: the library binding and the bake framework. Never imports bpy, so it works
from plain Python (``/usr/bin/python3``) as well as inside Blender.

    from hydrobake import core
    core.image.normal_map(height)           # numpy in, numpy out
    core.exr.write(path, {"R": r, "G": g})  # atomic EXR through OpenEXRCore
"""
from . import errors  # noqa: F401  (importable even when the library is missing)
from ._lib import library_path, version  # noqa: F401
from . import arrays, exr, image, params  # noqa: F401
from .errors import HydrobakeError, InvalidArgument, Cancelled  # noqa: F401
