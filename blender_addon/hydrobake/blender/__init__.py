"""Blender side of Hydrobake: properties, operators, panels and the bridge between Blender data
and numpy. Everything here may import bpy; hydrobake.core never does."""
