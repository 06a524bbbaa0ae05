"""Hydrobake: water-and-weather effects baked by a C core.

This file stays importable without Blender: ``hydrobake.core`` is the binding and bake
framework for plain Python; the Blender parts are imported only when Blender registers the
addon."""

bl_info = {
    "name": "Hydrobake",
    "author": "Hydrobake developers",
    "version": (0, 1, 0),
    "blender": (3, 4, 0),
    "location": "Properties > Physics > Hydrobake",
    "description": "Windshield rain, caustics, snow and advected fluid textures, baked by a "
                   "C core into images, materials and OpenVDB grids",
    "category": "Physics",
}


def register():
    from .blender import registration
    registration.register()


def unregister():
    from .blender import registration
    registration.unregister()
