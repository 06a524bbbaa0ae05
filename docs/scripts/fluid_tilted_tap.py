"""Measures how much water a tilted Inflow pours (why its lattice is laid along the flow): a
ball tap of radius 0.1 m and a 20 x 12 x 10 cm box tap in a 1 m box at 16 cells a side
(spacing 2 cm), no gravity, pouring at 1 m/s along z, along (0.6, 0, -0.8) and along the
diagonal. Per tap and direction: the particles poured over frames 2 to 7 of 1/24 s, and that
as a share of its cross-section's flow (area across the flow x 1 m/s x 0.25 s / spacing^3): 1
where a tap pours its velocity times its cross-section, whichever way it points (a little
under: the lattice rounds the shape, and a window cuts whole rows).

    PYTHONPATH=blender_addon /usr/bin/python3 docs/scripts/fluid_tilted_tap.py

(the built library in blender_addon/hydrobake/lib). On the world's lattice (f1ee66b, before
the lattice along the flow) the shares were ball 0.98 / 0.82 / 0.40 and box 0.96 / 0.66 / 0.39;
since, 0.98 / 0.98 / 0.92 and 0.96 / 0.96 / 0.83 (a box seen along its diagonal is a hexagon,
whose edges the lattice rounds off).
"""
import math

import numpy as np

from hydrobake.core import fluid

PARAMS = {"resolution": (16, 16, 16), "gravity": (0.0, 0.0, 0.0), "viscosity": 0.01,
          "max_particles": 40000, "threads": 2}
S, T = 0.02, 6 / 24
E = np.array((0.1, 0.06, 0.05))  # the box's half sizes
TAPS = {"ball": (("sphere", (0.5, 0.5, 0.5), 0.1), lambda d: math.pi * 0.1 ** 2),
        # a box's area across d: 4 (ey ez |dx| + ex ez |dy| + ex ey |dz|)
        "box": (("box", (0.5, 0.5, 0.5), tuple(E)),
                lambda d: 4 * (E[1] * E[2] * abs(d[0]) + E[0] * E[2] * abs(d[1]) +
                               E[0] * E[1] * abs(d[2])))}
DIRECTIONS = [(0.0, 0.0, -1.0), (0.6, 0.0, -0.8), tuple(np.array((1.0, 1.0, -1.0)) / 3 ** 0.5)]

for name, (shape, across) in TAPS.items():
    for d in DIRECTIONS:
        with fluid.Fluid(PARAMS) as f:
            f.set_inflow(shape, d)
            f.step()
            first = f.particle_count
            for _ in range(6):
                f.step()
            n = f.particle_count - first
        print(f"{name} along ({d[0]:.3g}, {d[1]:.3g}, {d[2]:.3g}): {n} particles, share "
              f"{n / (across(d) * T / S ** 3):.2f}")
