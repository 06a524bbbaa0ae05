"""Helpers the Blender tests share (imported by plain pytest, not inside Blender)."""
import glob
import json
import os
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, os.path.join(ROOT, "blender_addon"))


def frames_in(folder):
    """Frames the manifest of ``folder`` records as complete ([] if none yet)."""
    try:
        with open(os.path.join(folder, "manifest.json")) as f:
            return sorted(int(k) for k in json.load(f)["frames"])
    except (FileNotFoundError, ValueError):
        return []


def addon_zip():
    zips = sorted(glob.glob(os.path.join(ROOT, "dist", "hydrobake-*.zip")))
    if not zips:
        raise FileNotFoundError("dist/hydrobake-*.zip is missing: run build/package.sh")
    return zips[-1]
