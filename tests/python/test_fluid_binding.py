"""Solid fluid texturing through the binding: uvw advected exactly by a uniform flow, blend
weights normalised, closed surfaces, VDB output, determinism and resume."""
import numpy as np
import pytest

from hydrobake.core import errors, fluid, vdb
from hydrobake.core.bake import BakeRunner
from hydrobake.core.effects import get

GRID = {"source": "VELOCITY_GRID", "resolution": (8, 8, 8), "box_min": (0, 0, 0),
        "box_max": (1, 1, 1), "dt": 0.05, "reset_period": 0.0, "uvw_tile": 1.0}


def test_uniform_flow_shifts_uvw_by_v_dt():
    with fluid.Fluid(GRID) as f:
        nx, ny, nz = f.vertices
        vel = np.zeros((nz, ny, nx, 3), np.float32)
        vel[..., 0] = 0.5  # m/s along x: 0.025 m per frame = 0.2 voxels
        f.set_velocity_grid(vel, np.ones((nz, ny, nx), np.float32))
        before = f.volume("uvw_a")
        f.step()
        after = f.volume("uvw_a")
        # Semi-Lagrangian: the value now at x came from x - v dt; away from the inflow wall the
        # u coordinate (x / tile) drops by exactly 0.025, modulo the wrap.
        du = (before[2:-2, 2:-2, 2:-2, 0] - after[2:-2, 2:-2, 2:-2, 0]) % 1.0
        np.testing.assert_allclose(du, 0.025, atol=1e-5)
        np.testing.assert_array_equal(before[..., 1:], after[..., 1:])  # v, w untouched


def shear(f, rate, frames):
    """Steps f through `frames` frames of the shear flow vx = rate (z - 1/2) (z in the unit
    box), fluid everywhere; returns z per vertex layer, shaped to broadcast."""
    nx, ny, nz = f.vertices
    z = np.linspace(0.0, 1.0, nz, dtype=np.float32)[:, None, None]
    vel = np.zeros((nz, ny, nx, 3), np.float32)
    vel[..., 0] = rate * (z - 0.5)
    f.set_velocity_grid(vel, np.ones((nz, ny, nx), np.float32))
    for _ in range(frames):
        f.step()
    return z


def test_unwrapped_uvw_is_the_field_plus_whole_tiles_near_the_rest_mapping():
    # A shear flow, 1.5 s: the top and bottom layers travel 0.75 m, three tiles, so the
    # unwrapping has to choose tiles there; in between the shift is under half a tile.
    p = dict(GRID, resolution=(32, 32, 32), dt=1 / 24, reset_period=0.0, uvw_tile=0.25,
             max_flow=8.0)
    with fluid.Fluid(p) as f:
        nx, ny, nz = f.vertices
        z = shear(f, 1.0, 36)
        for field in ("uvw_a", "uvw_b"):
            wrapped, unwrapped = f.volume(field), f.volume(field + "_unwrapped")
            tiles = unwrapped - wrapped
            np.testing.assert_allclose(tiles, np.round(tiles), atol=1e-5)
            idx = np.stack(np.meshgrid(np.arange(nx), np.arange(ny), np.arange(nz),
                                       indexing="ij"), -1).transpose(2, 1, 0, 3)
            rest = idx * (1.0 / 32) / 0.25
            assert np.abs(unwrapped - rest).max() <= 0.5 + 1e-5
            # Where the layers moved under half a tile, neighbours along the flow differ by a
            # voxel's worth (1/8 tile), never by a wrap.
            calm = np.abs(z[:, 0, 0] - 0.5) * 1.5 < 0.125 - 1e-3
            step = np.diff(unwrapped[calm][..., 0], axis=-1)[..., 8:-8]  # past the inflows
            np.testing.assert_allclose(step, 0.125, atol=1e-3)
            assert np.abs(np.diff(wrapped[calm][..., 0], axis=-1)).max() > 0.8  # it wraps


def test_blend_weights_stay_normalised_after_paint():
    with fluid.Fluid(dict(GRID, textures=3)) as f:
        nx, ny, nz = f.vertices
        f.set_velocity_grid(np.full((nz, ny, nx, 3), 0.3, np.float32))
        f.paint_sphere(2, (0.5, 0.5, 0.5), 0.3, 0.1)
        for _ in range(3):
            f.step()
        b = f.volume("blend")
        np.testing.assert_allclose(b.sum(axis=-1), 1.0, atol=1e-5)
        assert b[..., 2].max() > 0.5  # the paint is there


def shear_run(stretch_fade, frames=18):
    """A shear flow vx = 2 (z - 1/2) 1/s: A reset at frame 0, B at frame 12 (period 1 s)."""
    p = dict(GRID, resolution=(32, 32, 32), dt=1 / 24, reset_period=1.0, uvw_tile=0.25,
             max_flow=8.0, stretch_fade=stretch_fade)
    with fluid.Fluid(p) as f:
        shear(f, 2.0, frames)
        mesh = f.surface()
        return f.uvw_weight(), f.volume("uvw_weight")[..., 0], mesh


def test_cross_fade_weight_per_voxel_with_stretch_fade():
    # Off: the frame's weight everywhere, in the grid and on the surface.
    w, grid, mesh = shear_run(0.0)
    assert w == pytest.approx(0.5)
    np.testing.assert_array_equal(grid, np.float32(w))
    np.testing.assert_array_equal(mesh["uvw_weight"], np.float32(w))
    # On: A (18 frames old) is more stretched than B (6 frames): A fades out early in the
    # middle band, away from the inflow walls, to w fA / (w fA + (1 - w) fB).
    w, grid, mesh = shear_run(0.5)
    fa, fb = np.exp(-(2 * 0.75) ** 2 / 3 / 0.5), np.exp(-(2 * 0.25) ** 2 / 3 / 0.5)
    band = grid[11:22, 2:-2, 10:23]  # |z - 1/2| <= 0.16, 0.31 <= x <= 0.69
    assert band.mean() == pytest.approx(w * fa / (w * fa + (1 - w) * fb), abs=0.01)
    assert 0.0 <= grid.min() and grid.max() <= 1.0
    assert len(mesh["uvw_weight"]) == len(mesh["positions"])


def test_bad_parameters_name_themselves():
    with pytest.raises(errors.InvalidArgument, match=r"^resolution\[0\] = 2: must be in"):
        fluid.Fluid({"resolution": (2, 8, 8)})
    with pytest.raises(errors.InvalidArgument, match="source = 'MANTAFLOW'"):
        fluid.Fluid({"source": "MANTAFLOW"})


def bake(folder, threads, frames=(1, 3), resume=False):
    e = get("fluid")({"fluid": {"resolution": (12, 12, 12), "textures": 2,
                                "threads": threads, "substeps": 8}},
                     {"fill": ((0.05, 0.05, 0.05), (0.45, 0.45, 0.3)),
                      "paint": {2: [(1, (0.25, 0.25, 0.15), 0.1, 0.02)]}})
    BakeRunner(e, folder, *frames, checkpoint_every=2, resume=resume).run()
    mesh = e.mesh
    e.close()
    return mesh


def test_bake_writes_vdb_grids_and_a_closed_surface(tmp_path):
    mesh = bake(tmp_path / "a", 1)
    grids = vdb.read(str(tmp_path / "a" / "fluid_0003.vdb"))
    assert {"density", "velocity", "uvw", "uvw_b", "blend_0", "blend_1"} <= set(grids)
    assert grids["velocity"].vectorType == "contravariant relative"
    assert grids["uvw"].vectorType == "invariant"
    # The texturing grids hold values where there is fluid and are inactive (zero) where there
    # is none; the renderers' unwrapped uvw is the fluid's own plus whole tiles.
    path = str(tmp_path / "a" / "fluid_0003.vdb")
    dens, uvw = vdb.read_grid(path, "density"), vdb.read_grid(path, "uvw")
    unw = vdb.read_grid(path, "uvw_unwrapped")
    n = np.minimum(dens.shape, unw.shape[:3])
    dens, uvw, unw = dens[:n[0], :n[1], :n[2]], uvw[:n[0], :n[1], :n[2]], unw[:n[0], :n[1], :n[2]]
    wet = dens > 0
    assert wet.any() and (~wet).any()
    tiles = unw[wet] - uvw[wet]
    np.testing.assert_allclose(tiles, np.round(tiles), atol=1e-5)
    assert not unw[~wet].any() and not uvw[~wet].any()
    assert 0 < grids["uvw"].activeVoxelCount() <= grids["density"].activeVoxelCount()
    # Closed: every edge is shared by exactly two triangles.
    t = mesh["triangles"]
    edges = np.sort(np.concatenate([t[:, [0, 1]], t[:, [1, 2]], t[:, [2, 0]]]), axis=1)
    _, counts = np.unique(edges, axis=0, return_counts=True)
    assert len(t) > 0 and np.all(counts == 2)


def test_without_a_density_the_texturing_grids_cover_the_box():
    # A velocity grid given without a surface field: no density to say where the fluid is.
    nv = GRID["resolution"][0] + 1
    vel = np.full((nv, nv, nv, 3), 0.1, np.float32)
    e = get("fluid")({"fluid": dict(GRID, textures=2)}, {"velocity": {1: (vel, None)}})
    try:
        e.step(1, None)
        grids = {g["name"]: g["array"] for g in e.outputs(1)["fluid"][1]}
    finally:
        e.close()
    assert not grids["density"].any()
    assert np.any(grids["uvw"] != 0, axis=-1).mean() > 0.9
    np.testing.assert_array_equal(grids["blend_0"] + grids["blend_1"], 1.0)


def grid_values(path):
    """Every grid's active values and bounding box. (A .vdb file also holds a random UUID that
    OpenVDB draws on every write, so files are compared by content, not bytes.)"""
    out = {}
    for name, g in vdb.read(str(path)).items():
        lo, hi = g.evalActiveVoxelBoundingBox()
        shape = tuple(max(b - a + 1, 0) for a, b in zip(lo, hi))
        if 0 in shape:  # no active voxels
            out[name] = (None, None, b"")
            continue
        arr = np.zeros(shape + ((3,) if g.valueTypeName.startswith("vec3") else ()), np.float32)
        g.copyToArray(arr, ijk=lo)
        out[name] = (lo, hi, arr.tobytes())
    return out


def test_same_values_for_any_thread_count_and_after_resume(tmp_path):
    bake(tmp_path / "a", 1, frames=(1, 4))
    bake(tmp_path / "b", 2, frames=(1, 4))
    bake(tmp_path / "c", 2, frames=(1, 2))
    bake(tmp_path / "c", 1, frames=(1, 4), resume=True)
    for i in range(1, 5):
        a = grid_values(tmp_path / "a" / f"fluid_{i:04d}.vdb")
        assert a == grid_values(tmp_path / "b" / f"fluid_{i:04d}.vdb")
        assert a == grid_values(tmp_path / "c" / f"fluid_{i:04d}.vdb")
        name = f"surface_{i:04d}.npz"  # the mesh files are byte-identical
        assert (tmp_path / "a" / name).read_bytes() == (tmp_path / "b" / name).read_bytes()
        assert (tmp_path / "a" / name).read_bytes() == (tmp_path / "c" / name).read_bytes()


@pytest.mark.parametrize("change, want", [
    # A feature rule added after the cancel: the checkpoint would bring back the rules of
    # the bake, and the new rule would silently do nothing.
    ({"rules": [(1, [0.0] + [-3e38] * 5, [900.0] + [3e38] * 5)]},
     r"rules: not in the bake, \[\[1, "),
    # A paint stroke moved: later frames would carry the new one, earlier ones the old.
    ({"paint": {2: [(1, (0.3, 0.25, 0.15), 0.1, 0.02)]}},
     r"paint\.2: \[\[1, \[0\.25, 0\.25, 0\.15\], .* in the bake, \[\[1, \[0\.3, "),
    # Points painted on the surface at another place (their arrays: by digest).
    ({"paint_points": {2: [(1, np.array([[0.3, 0.3, 0.1]], np.float32), None, 0.05,
                            0.02)]}},
     r"paint_points: not in the bake"),
], ids=["rule", "stroke", "points"])
def test_resume_refuses_changed_rules_and_paint(tmp_path, change, want):
    bake(tmp_path / "c", 1, frames=(1, 2))
    inputs = {"fill": ((0.05, 0.05, 0.05), (0.45, 0.45, 0.3)),
              "paint": {2: [(1, (0.25, 0.25, 0.15), 0.1, 0.02)]}}
    e = get("fluid")({"fluid": {"resolution": (12, 12, 12), "textures": 2, "threads": 1,
                                "substeps": 8}}, dict(inputs, **change))
    try:
        with pytest.raises(errors.StateError, match=r"^cannot resume the bake in .*: " + want):
            BakeRunner(e, tmp_path / "c", 1, 4, checkpoint_every=2, resume=True).run()
    finally:
        e.close()
    # The same inputs resume (the digest of a point stroke is stable).
    e = get("fluid")({"fluid": {"resolution": (12, 12, 12), "textures": 2, "threads": 1,
                                "substeps": 8}}, dict(inputs, **change))
    try:
        BakeRunner(e, tmp_path / "d", 1, 2, checkpoint_every=2).run()
    finally:
        e.close()
    e = get("fluid")({"fluid": {"resolution": (12, 12, 12), "textures": 2, "threads": 1,
                                "substeps": 8}}, dict(inputs, **change))
    try:
        r = BakeRunner(e, tmp_path / "d", 1, 3, checkpoint_every=2, resume=True)
        r.run()
        assert r.resumed_from == 2
    finally:
        e.close()


def test_sph_takes_the_steps_stability_needs():
    # One asked-for step per 1/24 s frame is 40x too long for h = 4 cm and a 14 m/s sound
    # speed: the core cuts each frame into steps of at most 0.4 h / (sqrt(k) + v_max).
    p = {"resolution": (16, 16, 16), "box_max": (1, 1, 0.5), "substeps": 1, "dt": 1 / 24,
         "max_particles": 2000}
    with fluid.Fluid(p) as f:
        assert f.substeps_taken == 0
        f.fill_box((0, 0, 0), (0.2, 0.2, 0.3))
        h, c = 0.04, 200.0 ** 0.5
        energy = []
        for _ in range(6):
            vmax = float(np.linalg.norm(f.particles()[1], axis=1).max())
            f.step()
            assert f.substeps_taken >= np.ceil((1 / 24) * (c + vmax) / (0.4 * h) - 1e-6)
            pos, vel = f.particles()
            energy.append(float(np.mean(0.5 * (vel ** 2).sum(1) + 9.81 * pos[:, 2])))
        assert f.substeps_taken < 100
        # A stable fluid only loses mechanical energy (an unstable one gains it and sprays).
        assert all(b <= a * 1.001 for a, b in zip(energy, energy[1:]))


def test_paint_points_lays_the_largest_coverage_on_its_frame_after_the_step():
    nx = ny = nz = 9
    still = (np.zeros((nz, ny, nx, 3), np.float32), np.ones((nz, ny, nx), np.float32))
    pts = np.array([[0.5, 0.5, 0.5], [0.5, 0.5, 0.5], [0.125, 0.125, 0.125]], np.float32)
    e = get("fluid")({"fluid": dict(GRID, textures=3, default_texture=0)},
                     {"velocity": {1: still},
                      "paint_points": {2: [(2, pts, np.array([0.3, 0.7, 0.0]), 0.13, 0.0)]}})
    try:
        e.step(1, None)
        assert e.fluid.volume("blend")[..., 2].max() == 0.0  # not before its frame
        e.step(2, None)
        b = e.fluid.volume("blend")
        assert b[4, 4, 4, 2] == pytest.approx(0.7)  # the larger of the two, on the step's frame
        assert b[4, 4, 3, 2] == pytest.approx(0.7)  # 0.125 m away: within the 0.13 m radius
        assert b[4, 4, 2, 2] == 0.0 and b[1, 1, 1, 2] == 0.0  # beyond it, and no coverage
        assert b[4, 4, 4, 0] == pytest.approx(0.3)  # the base shows through the rest
        np.testing.assert_allclose(b.sum(axis=-1), 1.0, atol=1e-6)
    finally:
        e.close()


def test_grid_sized_inputs_are_checked_before_the_library_reads_them():
    with fluid.Fluid(dict(GRID, textures=2)) as f:
        with pytest.raises(errors.InvalidArgument, match=r"mask: 5 values, must be 729"):
            f.paint_mask(1, np.zeros(5))
        with pytest.raises(errors.InvalidArgument, match=r"velocity: 3 values, must be 2187"):
            f.set_velocity_grid(np.zeros(3))
        with pytest.raises(errors.InvalidArgument, match=r"surface: 1 values, must be 729"):
            f.set_velocity_grid(np.zeros((9, 9, 9, 3)), np.zeros(1))
        with pytest.raises(errors.InvalidArgument, match=r"coverage: 1 values for 2 points"):
            f.paint_points(1, np.zeros((2, 3)), [1.0], 0.1)
        with pytest.raises(errors.InvalidArgument, match=r"radius = 5: must be in \[0, 2\] m"):
            f.paint_points(1, np.zeros((2, 3)), None, 5.0)
        f.paint_points(1, np.zeros((0, 3)), None, 0.1)  # no points: nothing painted
        assert f.volume("blend")[..., 1].max() == 0.0


def test_features_of_a_known_flow():
    # Paper §3.2 on a grid source whose surface field s = 2 - 2 z is the density feature (the
    # outward normal is +z): the angle between V_m and it, the density's rate and the flow's
    # acceleration between two frames, the divergence of a linear flow, and V_m clamped to
    # max_flow voxels per frame with its direction kept.
    p = dict(GRID, resolution=(16, 16, 16), dt=0.1, max_flow=8.0)  # 5 m/s at most
    with fluid.Fluid(p) as f:
        nx, ny, nz = f.vertices
        z, y, x = np.meshgrid(*(np.linspace(0, 1, n, dtype=np.float32) for n in (nz, ny, nx)),
                              indexing="ij")
        s = 2 - 2 * z
        v1 = np.zeros((nz, ny, nx, 3), np.float32)
        v1[...] = (0.3, 0.0, 0.4)
        f.set_velocity_grid(v1, s)
        f.step()
        v2 = np.stack([0.5 * x, -0.2 * y, 0.3 * z + 0.1], -1).astype(np.float32)
        f.set_velocity_grid(v2, s + 0.05)
        f.step()
        feat = f.volume("features")[1:-1, 1:-1, 1:-1]
        inner = v2[1:-1, 1:-1, 1:-1]
        names = fluid.FEATURES
        np.testing.assert_allclose(feat[..., names.index("density")], (s + 0.05)[1:-1, 1:-1, 1:-1])
        np.testing.assert_allclose(feat[..., names.index("density_rate")], 0.5, atol=2e-5)
        angle = np.arccos(inner[..., 2] / np.linalg.norm(inner, axis=-1))
        np.testing.assert_allclose(feat[..., names.index("flow_angle")], angle, atol=1e-5)
        acc = np.linalg.norm(inner - v1[1:-1, 1:-1, 1:-1], axis=-1) / 0.1
        np.testing.assert_allclose(feat[..., names.index("acceleration")], acc, rtol=1e-5)
        np.testing.assert_allclose(feat[..., names.index("divergence")], 0.6, atol=2e-5)
        v3 = np.zeros_like(v1)
        v3[...] = (6.0, 8.0, 0.0)  # 10 m/s
        f.set_velocity_grid(v3, s)
        f.step()
        np.testing.assert_allclose(f.volume("motion"), np.broadcast_to((3.0, 4.0, 0.0), v3.shape),
                                   atol=1e-5)


def test_moving_obstacles_are_checked_by_name():
    with fluid.Fluid({"resolution": (8, 8, 8)}) as f:
        f.set_obstacles([("box", (0.5, 0.5, 0.5), (0.1, 0.1, 0.1))])
        with pytest.raises(errors.InvalidArgument, match=r"to\[0\]\.type = 0: must be obstacle "
                                                         r"0's type 1"):
            f.move_obstacles([("sphere", (0.5, 0.5, 0.5), 0.1)])
        with pytest.raises(errors.InvalidArgument, match=r"count = 2: must be the obstacle "
                                                         r"count 1"):
            f.move_obstacles([("box", (0.5, 0.5, 0.5), (0.1, 0.1, 0.1))] * 2)
        with pytest.raises(errors.InvalidArgument, match=r"to\[0\]\.centre: must have 3"):
            f.move_obstacles([("box", (0.5, 0.5), (0.1, 0.1, 0.1))])
    with pytest.raises(errors.InvalidArgument, match=r"obstacle_path\[3\]: kinds \['sphere'\] "
                                                     r"must be the obstacles' \['box'\]"):
        get("fluid")({"fluid": {"resolution": (8, 8, 8)}},
                     {"fill": ((0, 0, 0), (0.3, 0.3, 0.3)),
                      "obstacles": [("box", (0.7, 0.5, 0.1), (0.1, 0.1, 0.1))],
                      "obstacle_path": {3: [("sphere", (0.5, 0.5, 0.5), 0.1)]}})


def test_a_moving_paddle_pushes_the_fluid_and_keeps_none_inside():
    """A box swept along -x at 1.2 m/s into shallow water: the water in front of it moves
    with its face (at its speed), none is left inside it, and the flow is several times that
    of the same box standing still."""
    params = {"fluid": {"resolution": (16, 16, 16), "max_particles": 20000, "substeps": 4}}
    box = lambda x: [("box", (x, 0.5, 0.1), (0.05, 0.3, 0.15))]  # noqa: E731
    fill = ((0, 0, 0), (0.8, 1, 0.12))
    moving = get("fluid")(params, {"fill": fill, "obstacles": box(0.9),
                                   "obstacle_path": {f: box(0.9 - 0.05 * f)
                                                     for f in range(1, 9)}})
    still = get("fluid")(params, {"fill": fill, "obstacles": box(0.9)})
    try:
        for f in range(1, 9):
            moving.step(f, None)
            still.step(f, None)
        pos, vel = moving.fluid.particles()
        x = 0.9 - 0.05 * 8
        inside = ((np.abs(pos[:, 0] - x) < 0.05 + 0.0099) & (np.abs(pos[:, 1] - 0.5) < 0.3) &
                  (pos[:, 2] < 0.25))
        assert not inside.any()
        front = (pos[:, 0] > x - 0.05 - 0.03) & (pos[:, 0] < x - 0.05) & \
            (np.abs(pos[:, 1] - 0.5) < 0.2)
        assert front.sum() > 100
        assert -1.25 < np.median(vel[front, 0]) < -1.15
        svel = still.fluid.particles()[1]
        assert np.abs(vel[:, 0]).mean() > 2.5 * np.abs(svel[:, 0]).mean()
    finally:
        moving.close()
        still.close()


def _about_z(angle):
    return (np.cos(angle / 2), 0.0, 0.0, np.sin(angle / 2))


def test_a_turning_paddle_stirs_the_water_and_keeps_none_inside():
    """A paddle standing in shallow water, turned about z at 4 rad/s (a turned box): the
    water takes up its turn (angular momentum about the axis, the same sign) and none is left
    inside it; standing still, the same paddle stirs nothing."""
    params = {"fluid": {"resolution": (16, 16, 16), "max_particles": 20000, "substeps": 4}}
    omega, dt, frames = 4.0, 1 / 24, 8
    paddle = lambda f: [("turned_box", (0.5, 0.5, 0.1), (0.3, 0.02, 0.15),  # noqa: E731
                         _about_z(omega * dt * f))]
    fill = ((0, 0, 0), (1, 1, 0.12))
    turning = get("fluid")(params, {"fill": fill, "obstacles": paddle(0),
                                    "obstacle_path": {f: paddle(f)
                                                      for f in range(1, frames + 1)}})
    still = get("fluid")(params, {"fill": fill, "obstacles": paddle(0)})
    try:
        for f in range(1, frames + 1):
            turning.step(f, None)
            still.step(f, None)

        def spin(effect):
            pos, vel = effect.fluid.particles()
            r = pos[:, :2] - 0.5
            return (r[:, 0] * vel[:, 1] - r[:, 1] * vel[:, 0]).sum(), pos

        lz, pos = spin(turning)
        still_lz = spin(still)[0]
        assert lz > 20 * abs(still_lz) and lz > 0
        phi = omega * dt * frames
        along = (pos[:, 0] - 0.5) * np.cos(phi) + (pos[:, 1] - 0.5) * np.sin(phi)
        across = -(pos[:, 0] - 0.5) * np.sin(phi) + (pos[:, 1] - 0.5) * np.cos(phi)
        inside = (np.abs(along) < 0.3 + 0.0099) & (np.abs(across) < 0.02 + 0.0099) & \
            (pos[:, 2] < 0.25 + 0.0099)
        assert not inside.any()
        # where it stood at the start (a quarter of a turn away) water came back in
        assert (np.abs(pos[:, 1] - 0.5) < 0.02).sum() > 50
        # the frame's inputs name the turn: a resume would see a changed one
        assert turning.frame_inputs(3)["obstacles"] != turning.frame_inputs(4)["obstacles"]
    finally:
        turning.close()
        still.close()


def test_a_box_cannot_become_a_turned_box_along_its_path():
    with pytest.raises(errors.InvalidArgument, match=r"obstacle_path\[2\]: kinds "
                                                     r"\['turned_box'\] must be the obstacles' "
                                                     r"\['box'\]"):
        get("fluid")({"fluid": {"resolution": (8, 8, 8)}},
                     {"fill": ((0, 0, 0), (0.3, 0.3, 0.3)),
                      "obstacles": [("box", (0.7, 0.5, 0.1), (0.1, 0.1, 0.1))],
                      "obstacle_path": {2: [("turned_box", (0.7, 0.5, 0.1), (0.1, 0.1, 0.1),
                                             _about_z(0.3))]}})


def _torus_field(e, n, ring, tube):
    """Signed distances to a torus about z (ring and tube radii) at n points a side over the
    box of half-sizes e, as (nz, ny, nx)."""
    z, y, x = np.meshgrid(*(np.linspace(-h, h, n) for h in e[::-1]), indexing="ij")
    return (np.hypot(np.hypot(x, y) - ring, z) - tube).astype(np.float32)


def test_water_falls_through_a_mesh_ring_and_not_into_it():
    """A block of water dropped on a ring lying flat (a mesh obstacle: a torus's distance
    field): water falls through its hole to the floor and none enters the tube; the same ring
    as its box (a turned box) holds all the water above it."""
    params = {"fluid": {"resolution": (16, 16, 16), "max_particles": 20000, "substeps": 4}}
    e, ring, tube = (0.32, 0.32, 0.1), 0.2, 0.08
    field = _torus_field(e, 48, ring, tube)
    q = (np.cos(0.2), np.sin(0.2), 0.0, 0.0)  # tilted a little about x
    mesh = [("mesh", (0.5, 0.5, 0.35), e, q, field)]
    box = [("turned_box", (0.5, 0.5, 0.35), (0.28, 0.28, 0.08), q)]
    fill = ((0.35, 0.35, 0.5), (0.65, 0.65, 0.7))
    effects = [get("fluid")(params, {"fill": fill, "obstacles": obs}) for obs in (mesh, box)]
    try:
        for f in range(1, 8):
            for effect in effects:
                effect.step(f, None)
        (pos, _), (bpos, _) = (effect.fluid.particles() for effect in effects)

        def below(p):  # under the ring, within its hole's radius
            return ((p[:, 2] < 0.25) & (np.hypot(p[:, 0] - 0.5, p[:, 1] - 0.5) < 0.1)).sum()

        assert below(pos) > 300 and below(bpos) == 0, (below(pos), below(bpos))
        # none in the tube (in the ring's own axes: turned back about x)
        rel = pos - (0.5, 0.5, 0.35)
        c, s = np.cos(0.4), np.sin(0.4)
        local = np.stack([rel[:, 0], c * rel[:, 1] + s * rel[:, 2],
                          -s * rel[:, 1] + c * rel[:, 2]], axis=1)
        d = np.hypot(np.hypot(local[:, 0], local[:, 1]) - ring, local[:, 2]) - tube
        assert d.min() > 0.0099 - 0.002, d.min()  # (the field's cells: 1.4 cm)
        # the manifest records the field by its digest, and a changed field is a change
        inputs = effects[0].scalar_inputs()["obstacles"]
        assert isinstance(inputs[0][4], str) and len(str(inputs)) < 400, inputs
        other = get("fluid")(params, {"fill": fill, "obstacles": [
            mesh[0][:4] + (_torus_field(e, 48, ring, 0.07),)]})
        assert other.scalar_inputs()["obstacles"] != inputs
        other.close()
    finally:
        for effect in effects:
            effect.close()


def test_a_moving_mesh_keeps_its_shape_along_its_path():
    """A mesh's path entries may leave its field out (None): it keeps the one it has, moved."""
    params = {"fluid": {"resolution": (8, 8, 8), "max_particles": 12000}}
    e = (0.2, 0.2, 0.2)
    field = _torus_field(e, 16, 0.12, 0.05)
    at = lambda x: ("mesh", (x, 0.5, 0.3), e, (1, 0, 0, 0), None)  # noqa: E731
    effect = get("fluid")(params, {"fill": ((0, 0, 0), (0.4, 1, 0.2)),
                                   "obstacles": [("mesh", (0.5, 0.5, 0.3), e, (1, 0, 0, 0),
                                                  field)],
                                   "obstacle_path": {f: [at(0.5 - 0.02 * f)] for f in (1, 2)}})
    try:
        for f in (1, 2, 3):
            effect.step(f, None)
        assert effect.frame_inputs(1)["obstacles"] != effect.frame_inputs(2)["obstacles"]
    finally:
        effect.close()
    with pytest.raises(errors.InvalidArgument, match=r"obstacles\[0\]\.field: must be an array"):
        get("fluid")(params, {"obstacles": [("mesh", (0.5, 0.5, 0.3), e, (1, 0, 0, 0), None)]})


def _ball_field(e, n, radius):
    z, y, x = np.meshgrid(*(np.linspace(-h, h, n) for h in e[::-1]), indexing="ij")
    return (np.sqrt(x * x + y * y + z * z) - radius).astype(np.float32)


def test_a_mesh_that_deforms_takes_its_shape_at_each_frame():
    """A ball mesh growing frame by frame (a field of its own in every path entry): the water
    is pushed out of it as it grows, to the last frame's radius; a frame's inputs name its
    shape, so a resume would see one changed."""
    params = {"fluid": {"resolution": (16, 16, 16), "max_particles": 20000, "substeps": 4}}
    e = (0.25, 0.25, 0.25)
    ball = lambda r, field=True: ("mesh", (0.5, 0.5, 0.3), e, (1, 0, 0, 0),  # noqa: E731
                                  _ball_field(e, 40, r) if field else None)
    effect = get("fluid")(params, {"fill": ((0.2, 0.2, 0), (0.8, 0.8, 0.3)),
                                   "obstacles": [ball(0.06)],
                                   "obstacle_path": {f: [ball(0.06 + 0.03 * f)]
                                                     for f in (1, 2, 3, 4)}})
    try:
        for f in (1, 2, 3, 4):
            effect.step(f, None)
        pos = effect.fluid.particles()[0]
        d = np.linalg.norm(pos - (0.5, 0.5, 0.3), axis=1)
        assert d.min() > 0.18 + 0.0099 - 0.003, d.min()  # (the field's points 1.3 cm apart)
        assert ((d > 0.18) & (d < 0.22)).sum() > 100  # pushed, not gone
        a, b = (effect.frame_inputs(f)["obstacles"] for f in (2, 3))
        assert a != b
    finally:
        effect.close()
    # the same ball that does not grow (its field left out along the path) keeps its size
    still = get("fluid")(params, {"fill": ((0.2, 0.2, 0), (0.8, 0.8, 0.3)),
                                  "obstacles": [ball(0.06)],
                                  "obstacle_path": {f: [ball(0.06, False)] for f in (1, 2)}})
    try:
        for f in (1, 2, 3, 4):
            still.step(f, None)
        d = np.linalg.norm(still.fluid.particles()[0] - (0.5, 0.5, 0.3), axis=1)
        assert d.min() < 0.1
    finally:
        still.close()


def test_a_growing_mesh_throws_the_water_out_at_its_speed():
    """A ball mesh growing 3 cm a frame (fields of one shape along the path): the step changes
    one field into the next, so the water against it rides its surface out at the speed the
    surface grows (0.72 m/s). Fields of alternating shapes are taken at once: the water is put
    outside each new ball, without that speed, and most of it is left behind."""
    params = {"fluid": {"resolution": (16, 16, 16), "max_particles": 20000, "substeps": 4}}
    e = (0.25, 0.25, 0.25)

    def against(n_of):
        """How many particles lie against the ball at frame 3, and their median speed out."""
        ball = lambda f: ("mesh", (0.5, 0.5, 0.3), e, (1, 0, 0, 0),  # noqa: E731
                          _ball_field(e, n_of(f), 0.06 + 0.03 * f))
        effect = get("fluid")(params, {"fill": ((0.2, 0.2, 0), (0.8, 0.8, 0.3)),
                                       "obstacles": [ball(0)],
                                       "obstacle_path": {f: [ball(f)] for f in (1, 2, 3)}})
        try:
            for f in (1, 2, 3):
                effect.step(f, None)
            pos, vel = effect.fluid.particles()
        finally:
            effect.close()
        rel = pos - (0.5, 0.5, 0.3)
        d = np.linalg.norm(rel, axis=1)
        near = d < 0.15 + 0.0099 + 0.01  # within a centimetre of where it keeps them
        return int(near.sum()), float(np.median(np.sum(vel[near] * rel[near], axis=1) / d[near]))

    (n, speed), (n_at_once, speed_at_once) = against(lambda f: 40), against(lambda f: 40 + f % 2)
    assert n > 200 and abs(speed - 0.72) < 0.05, (n, speed)
    assert n_at_once < n / 5 and speed_at_once < 0.55, (n_at_once, speed_at_once)


def test_water_poured_in_a_shape_fills_it_and_nothing_else(tmp_path):
    """fill_shape: a torus lying tilted (a mesh's field) holds as many particles as its volume
    holds lattice cells (2 pi^2 R r^2 / spacing^3), all inside the tube, none in its hole; a
    sphere likewise; it is not kept as an obstacle (the water falls out of it); bad shapes
    are refused by name, and a shape with no lattice point inside is refused before a bake
    of nothing. The shape is part of what a resume compares."""
    params = {"fluid": {"resolution": (16, 16, 16), "max_particles": 20000, "substeps": 4}}
    e, ring, tube = (0.32, 0.32, 0.1), 0.2, 0.08
    q = (np.cos(0.2), np.sin(0.2), 0.0, 0.0)  # tilted about x by 0.4 rad
    torus = ("mesh", (0.5, 0.5, 0.4), e, q, _torus_field(e, 64, ring, tube))
    s = 0.02  # the default particle_spacing
    with fluid.Fluid(params["fluid"]) as f:
        f.fill_shape(torus)
        pos, vel = f.particles()
        assert len(pos) * s ** 3 == pytest.approx(2 * np.pi ** 2 * ring * tube ** 2, rel=0.05)
        assert not vel.any()
        c, sn = np.cos(0.4), np.sin(0.4)  # into the torus's own axes: turned back about x
        d = pos - (0.5, 0.5, 0.4)
        lx, ly, lz = d[:, 0], c * d[:, 1] + sn * d[:, 2], -sn * d[:, 1] + c * d[:, 2]
        assert np.all(np.hypot(np.hypot(lx, ly) - ring, lz) < tube + 0.005)
        assert np.hypot(lx, ly).min() > ring - tube - 0.005  # the hole stays empty
        f.fill_shape(("sphere", (0.5, 0.5, 0.85), 0.1), jitter=0.2)
        ball = f.particle_count - len(pos)
        assert ball * s ** 3 == pytest.approx(4 / 3 * np.pi * 0.001, rel=0.05)
        f.step()  # nothing holds it: the water falls
        assert f.particles()[1][:, 2].mean() < -0.1
        for shape, want in (
                (("sphere", (0.5, 0.5), 0.1), r"^shape\.centre: must have 3 numbers"),
                (("mesh", (0.5, 0.5, 0.5), e, (1, 0, 0, 0), None),
                 r"^shape\.field: must be an array"),
                (("turned_box", (0.5, 0.5, 0.5), e, (2, 0, 0, 0)),
                 r"^shape\.rotation: length 2, must be a unit quaternion")):
            with pytest.raises(errors.InvalidArgument, match=want):
                f.fill_shape(shape)
        with pytest.raises(errors.InvalidArgument, match=r"^jitter = 0\.9: must be in \[0, "):
            f.fill_shape(("sphere", (0.5, 0.5, 0.5), 0.1), jitter=0.9)
    with pytest.raises(errors.InvalidArgument, match=r"^fill_shape: no particle fits inside"):
        get("fluid")(params, {"fill_shape": ("sphere", (0.5, 0.5, 0.5), 0.005)})
    e1 = get("fluid")(params, {"fill_shape": torus})
    e2 = get("fluid")(params, {"fill_shape": torus[:4] + (torus[4] * 1.01,)})
    try:
        assert e1.scalar_inputs()["fill shape"] != e2.scalar_inputs()["fill shape"]
        assert e1.fluid.particle_count > 0
    finally:
        e1.close()
        e2.close()


def test_the_filled_water_starts_with_the_fill_velocity():
    """fill_velocity: every filled particle starts with it, the ball of water flies on at that
    speed (gravity off: its centre moves v dt a frame, to 1%); a fast start takes more SPH
    steps; bad values are refused by name; a resume sees it changed."""
    params = {"fluid": {"resolution": (16, 16, 16), "max_particles": 20000, "substeps": 1,
                        "gravity": (0.0, 0.0, 0.0)}}
    ball = ("sphere", (0.3, 0.5, 0.5), 0.1)
    still = get("fluid")(params, {"fill_shape": ball})
    thrown = get("fluid")(params, {"fill_shape": ball, "fill_velocity": (2.0, 0.0, 0.5)})
    try:
        pos0, vel0 = thrown.fluid.particles()
        assert np.all(vel0 == np.float32((2.0, 0.0, 0.5)))
        assert pos0.tobytes() == still.fluid.particles()[0].tobytes()
        still.fluid.step()
        thrown.fluid.step()
        pos1 = thrown.fluid.particles()[0]
        moved = pos1.astype(np.float64).mean(0) - pos0.astype(np.float64).mean(0)
        assert moved == pytest.approx(np.array((2.0, 0.0, 0.5)) / 24, rel=0.01, abs=1e-4)
        assert thrown.fluid.substeps_taken > still.fluid.substeps_taken
        assert thrown.scalar_inputs()["fill velocity"] == [2.0, 0.0, 0.5]
        assert "fill velocity" not in still.scalar_inputs()
    finally:
        still.close()
        thrown.close()
    for v, want in (((1.0, 2.0), r"^fill_velocity: must have 3 numbers, got 2"),
                    ((0.0, 2e3, 0.0), r"^fill_velocity = \(0, 2000, 0\): each component must "
                                      r"be a finite number in \[-1000, 1000\] m/s")):
        with pytest.raises(errors.InvalidArgument, match=want):
            get("fluid")(params, {"fill_shape": ball, "fill_velocity": v})
