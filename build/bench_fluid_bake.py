"""A whole fluid bake, as an artist's runs, timed by stage: the 128^3 dam break of bench_fluid
(100k particles, one paint stroke) baked through the real BakeRunner into a temporary folder,
VDB, surface and checkpoint files included. A benchmark, not a test.

Usage: /usr/bin/python3 build/bench_fluid_bake.py [frames] [resolution]
(after build/build.sh; Blender's Python, with numpy and pyopenvdb).
"""
import argparse
import os
import shutil
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "blender_addon"))

from hydrobake.core.bake import BakeRunner  # noqa: E402
from hydrobake.core.effects import get  # noqa: E402
from hydrobake.core.fluid import Fluid  # noqa: E402


def int_in(lo, hi):
    """An argparse type: an integer in [lo, hi], refused with the range otherwise."""
    def parse(text):
        try:
            value = int(text)
        except ValueError:
            value = None
        if value is None or not lo <= value <= hi:
            raise argparse.ArgumentTypeError(f"must be an integer in [{lo}, {hi}], got {text!r}")
        return value
    return parse


def main():
    parser = argparse.ArgumentParser(description="A whole fluid bake, timed by stage.")
    parser.add_argument("frames", nargs="?", type=int_in(1, 10000), default=6)
    res_range = Fluid.spec().by_name["resolution"]  # the library's own range
    parser.add_argument("resolution", nargs="?", default=128,
                        type=int_in(int(res_range.min), int(res_range.max)))
    args = parser.parse_args()
    frames, res = args.frames, args.resolution
    params = {"fluid": {"resolution": (res,) * 3, "textures": 3, "threads": 2, "substeps": 1,
                        "max_particles": 100000, "particle_spacing": 0.015,
                        "smoothing_length": 0.03, "metaball_radius": 0.03, "dt": 1 / 24}}
    effect = get("fluid")(params, {"fill": ((0, 0, 0), (0.69, 0.69, 0.69)),
                                   "paint": {1: [(1, (0.2, 0.2, 0.2), 0.15, 0.05)]}})
    folder = tempfile.mkdtemp(prefix="hbk_bench_bake_")
    runner = BakeRunner(effect, folder, 1, frames)
    spent = {"simulation (step)": 0.0, "outputs (volumes to arrays)": 0.0,
             "files and checkpoint, side by side": 0.0,
             "(the checkpoint alone, in its thread)": 0.0}

    def timed(key, fn):
        def wrapper(*args, **kwargs):
            t = time.perf_counter()
            try:
                return fn(*args, **kwargs)
            finally:
                spent[key] += time.perf_counter() - t
        return wrapper

    effect.step = timed("simulation (step)", effect.step)
    effect.outputs = timed("outputs (volumes to arrays)", effect.outputs)
    runner._write_all = timed("files and checkpoint, side by side", runner._write_all)
    runner._checkpoint = timed("(the checkpoint alone, in its thread)", runner._checkpoint)
    t = time.perf_counter()
    try:
        runner.run()
        total = time.perf_counter() - t
        sizes = {}
        for name in os.listdir(folder):
            kind = name.split("_")[0]
            sizes[kind] = sizes.get(kind, 0) + os.path.getsize(os.path.join(folder, name))
    finally:
        effect.close()
        shutil.rmtree(folder, ignore_errors=True)
    print(f"Fluid bake, {res}^3, {frames} frames of 1/24 s, 2 threads: "
          f"{total / frames:.2f} s per frame")
    print("| stage | s per frame | share |")
    print("|---|---:|---:|")
    for key, value in spent.items():
        print(f"| {key} | {value / frames:.2f} | {100 * value / total:.0f}% |")
    print("files per frame: " + ", ".join(f"{k} {v / frames / 1e6:.0f} MB"
                                          for k, v in sorted(sizes.items())))


if __name__ == "__main__":
    main()
