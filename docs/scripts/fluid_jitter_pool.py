"""Measures what a jittered fill does to still water (why Blender's Fill and Inflow keep to the
lattice): a pool 15 cm deep in a 0.8 x 0.5 x 0.6 m box at 40 x 25 x 30 cells, filled on the
lattice or with each point moved by up to JITTER spacings, stepped six frames of 1/24 s. Per
frame: the fastest particle's speed (m/s), the root-mean-square speed, how far the highest
particle has risen above the pool's top (m), and the SPH steps the frame took.

    PYTHONPATH=blender_addon /usr/bin/python3 docs/scripts/fluid_jitter_pool.py [JITTER ...]

(default 0 0.05 0.1 0.2 0.3; the built library in blender_addon/hydrobake/lib)
"""
import sys

import numpy as np

from hydrobake.core import fluid

PARAMS = {"resolution": (40, 25, 30), "box_min": (0.0, 0.0, 0.0), "box_max": (0.8, 0.5, 0.6),
          "threads": 2, "dt": 1 / 24}
for jitter in map(float, sys.argv[1:] or (0, 0.05, 0.1, 0.2, 0.3)):
    with fluid.Fluid(PARAMS) as f:
        f.fill_box((0.0, 0.0, 0.0), (0.8, 0.5, 0.15), jitter)
        top = f.particles()[0][:, 2].max()
        rows = []
        for _ in range(6):
            f.step()
            pos, vel = f.particles()
            speed = np.linalg.norm(vel, axis=1)
            rows.append(f"{speed.max():.2f} {np.sqrt((speed ** 2).mean()):.3f} "
                        f"{pos[:, 2].max() - top:+.3f} {f.substeps_taken}")
        print(f"jitter {jitter:g}, {len(pos)} particles: " + " | ".join(rows))
