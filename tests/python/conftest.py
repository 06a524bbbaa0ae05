"""Binding tests run from plain /usr/bin/python3 against the built library, without bpy."""
import os
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, os.path.join(ROOT, "blender_addon"))
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
