"""Measures how much water a sprinkler (an Inflow with a Normal velocity) pours against the
rate the library forecasts (hbk_fluid_inflow_rate: each surface point a column at its own
velocity): a ball of radius 0.1 m, a 20 x 12 x 10 cm box and that box turned 45 degrees about
x, spraying 1 m/s along the normal, and the ball pouring 1 m/s down plus 0.5 along the
normal; in a 1 m box at 16 cells a side (spacing 2 cm), no gravity. Per case: the surface
points, the particles poured over frames 2 to 7 of 1/24 s, and that as a share of the
forecast rate x 0.25 s (1 where the streams part and every point pours its column).

    PYTHONPATH=blender_addon /usr/bin/python3 docs/scripts/fluid_sprinkler_rate.py

(the built library in blender_addon/hydrobake/lib). Measured 2026-12-07: ball 0.96, box 0.96,
turned box 0.94; the ball with a velocity down as well 0.60 (the upper side's streams run
down past the lower points and keep some from pouring).
"""
from hydrobake.core import fluid

PARAMS = {"resolution": (16, 16, 16), "gravity": (0.0, 0.0, 0.0), "viscosity": 0.01,
          "max_particles": 60000, "threads": 2}
T = 6 / 24
HALF = (0.1, 0.06, 0.05)
CASES = [("ball", ("sphere", (0.5, 0.5, 0.5), 0.1), (0.0, 0.0, 0.0), 1.0),
         ("box", ("box", (0.5, 0.5, 0.5), HALF), (0.0, 0.0, 0.0), 1.0),
         ("turned box", ("turned_box", (0.5, 0.5, 0.5), HALF, (0.9238795, 0.3826834, 0.0, 0.0)),
          (0.0, 0.0, 0.0), 1.0),
         ("ball, 1 m/s down as well", ("sphere", (0.5, 0.5, 0.5), 0.1), (0.0, 0.0, -1.0), 0.5)]

for name, shape, velocity, normal in CASES:
    with fluid.Fluid(PARAMS) as f:
        f.set_inflow(shape, velocity, normal=normal)
        points, rate = f.inflow_points, f.inflow_rate
        f.step()
        first = f.particle_count
        for _ in range(6):
            f.step()
        n = f.particle_count - first
    print(f"{name}: {points} points, forecast {rate:.0f} a second, poured {n} particles, share "
          f"{n / (rate * T):.2f}")
