"""Moves data between Blender and numpy/files: images, materials, meshes, volumes."""
