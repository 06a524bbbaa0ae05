"""A resume refuses to continue a bake the scene has changed under. The arrays an effect takes
from the scene (a mesh, the ground) and what the scene's animation gives each frame (a
transform, the car's speed) are recorded as digests; a resume compares them for the frames it
keeps, and bakes the frames after its checkpoint from the scene as it is now."""
import json
import os
import shutil

import numpy as np
import pytest

from hydrobake.core import errors, mantaflow, vdb
from hydrobake.core.bake import BakeCache, BakeRunner
from hydrobake.core.effects import get
from test_fluid_binding import grid_values
from test_snow_binding import box_with_roof

POS, TRIS, UVS, MI = box_with_roof()
MOVED = np.eye(4)
MOVED[0, 3], MOVED[2, 3] = 0.7, -0.3


def snow(transforms=None, positions=POS):
    return get("snow")({"snow": {"flake_count": 3000, "texture_width": 32,
                                 "texture_height": 32, "wind": (1, 0, 0),
                                 "flake_radius": 0.01}},
                       {"positions": positions, "triangles": TRIS, "uvs": UVS,
                        "material_index": MI, "substeps": 2,
                        "transforms": {3: MOVED} if transforms is None else transforms,
                        "materials": [(0.4, False, False), (0.0, False, True)]})


def run(effect, folder, end=8, cancel_after=None, resume=False):
    """Bakes frames 1..end (checkpoints every 3 and the latest), cancelled once frame
    ``cancel_after`` is written; returns the runner."""
    r = BakeRunner(effect, folder, 1, end, checkpoint_every=3, resume=resume,
                   on_frame=lambda s: s.written == cancel_after and r.cancel())
    try:
        if cancel_after is None:
            r.run()
        else:
            with pytest.raises(errors.Cancelled):
                r.run()
    finally:
        effect.close()
    return r


def snapshot(folder):
    return {n: (folder / n).read_bytes() for n in sorted(os.listdir(folder))}


def frames(folder):
    """The frames' files (a resumed snow's checkpoints differ from a bake's that never
    stopped in a flag: whether the mesh was set since the last step)."""
    return {n: b for n, b in snapshot(folder).items() if n.endswith(".exr")}


def refused(effect, folder, want, end=8):
    """The resume is refused with ``want`` and leaves the folder as it was."""
    before = snapshot(folder)
    with pytest.raises(errors.StateError, match=r"^cannot resume the bake in .*: " + want +
                       r"; free it or bake anew$"):
        run(effect, folder, end, resume=True)
    assert snapshot(folder) == before


@pytest.fixture
def cut(tmp_path):
    """A snow bake of frames 1..8 (the mesh moved from frame 3) cancelled after frame 5."""
    folder = tmp_path / "cut"
    run(snow(), folder, cancel_after=5)
    m = BakeCache(folder).read_manifest()
    assert sorted(map(int, m["frames"])) == [1, 2, 3, 4, 5]
    assert set(m["scene"]) == {"mesh", "faces' material slots"}
    # Where the mesh is at each frame: at rest at 1 and 2, moved by frame 3's transform after.
    placed = [m["frame_inputs"][str(f)]["mesh position"] for f in (1, 2, 3, 5)]
    assert placed[0] == placed[1] != placed[2] == placed[3]
    return folder


def test_the_same_scene_resumes_bit_identical(cut, tmp_path):
    ref = tmp_path / "ref"
    run(snow(), ref)
    r = run(snow(), cut, resume=True)
    assert r.resumed_from == 5
    assert frames(cut) == frames(ref)
    assert BakeCache(cut).read_manifest()["frame_inputs"] == \
        BakeCache(ref).read_manifest()["frame_inputs"]


def test_a_changed_mesh_is_refused(cut):
    pos = POS.copy()
    pos[0, 2] += 0.01  # one vertex a centimetre higher
    refused(snow(positions=pos), cut, "mesh position at frame 1: changed since the bake")
    e = get("snow")({"snow": {"flake_count": 3000, "texture_width": 32, "texture_height": 32,
                              "wind": (1, 0, 0), "flake_radius": 0.01}},
                    {"positions": POS, "triangles": TRIS[:, ::-1], "uvs": UVS[:, ::-1],
                     "material_index": MI, "substeps": 2, "transforms": {3: MOVED},
                     "materials": [(0.4, False, False), (0.0, False, True)]})
    refused(e, cut, "mesh: changed since the bake")  # every face turned over
    e = get("snow")({"snow": {"flake_count": 3000, "texture_width": 32, "texture_height": 32,
                              "wind": (1, 0, 0), "flake_radius": 0.01}},
                    {"positions": POS, "triangles": TRIS, "uvs": UVS, "material_index": 1 - MI,
                     "substeps": 2, "transforms": {3: MOVED},
                     "materials": [(0.4, False, False), (0.0, False, True)]})
    refused(e, cut, "faces' material slots: changed since the bake")  # the roof's and box's


def test_a_mesh_that_starts_moving_after_the_kept_frames_resumes(tmp_path):
    """Blender gives a still mesh in the world, and a moving one at rest with a transform per
    frame: a bake of a still cube resumed once it moves later is the same scene up to then."""
    there = np.eye(4)
    there[:3, 3] = (0.25, -0.5, 0.125)
    placed = (POS.astype(np.float64) @ there[:3, :3].T + there[:3, 3]).astype(np.float32)
    folder = tmp_path / "bake"
    run(snow({}, positions=placed), folder, end=3)
    assert run(snow({1: there, 5: MOVED}), folder, end=6, resume=True).resumed_from == 3


def test_changed_animation_in_the_kept_frames_is_refused(cut):
    refused(snow({2: MOVED}), cut, "mesh position at frame 2: changed since the bake")
    refused(snow({}), cut, "mesh position at frame 3: changed since the bake")


def test_changed_animation_after_the_checkpoint_is_baked_from_the_scene(cut, tmp_path):
    later = MOVED.copy()
    later[1, 3] = 0.4
    ref = tmp_path / "ref"
    run(snow({3: MOVED, 7: later}), ref)
    r = run(snow({3: MOVED, 7: later}), cut, resume=True)
    assert r.resumed_from == 5
    assert frames(cut) == frames(ref)
    # Recorded for the frames baked now, so a later resume checks them too.
    refused(snow({3: MOVED, 7: MOVED}), cut, "mesh position at frame 7: changed since the bake")


def test_a_complete_bake_is_checked_too(tmp_path):
    folder = tmp_path / "bake"
    run(snow(), folder)
    refused(snow({4: MOVED}), folder, "mesh position at frame 3: changed since the bake")
    r = run(snow(), folder, resume=True)
    assert r.resumed_from == 8


def test_a_bake_from_before_the_digests_resumes(cut, tmp_path):
    """Manifests of earlier versions have no digests: nothing to compare, nothing refused."""
    path = cut / "manifest.json"
    m = json.loads(path.read_text())
    del m["scene"], m["frame_inputs"]
    path.write_text(json.dumps(m))
    ref = tmp_path / "ref"
    run(snow(), ref)
    r = run(snow(), cut, resume=True)
    assert r.resumed_from == 5
    m = BakeCache(cut).read_manifest()
    assert "frame_inputs" not in m  # (a record of frames 6-8 alone would refuse 1-5 later)
    for f in range(1, 9):
        assert m["frames"][str(f)] == BakeCache(ref).read_manifest()["frames"][str(f)]


@pytest.mark.parametrize("key, value, want", [
    ("scene", ["mesh"], "scene: not a list of digests"),
    ("scene", {"mesh": 3}, "scene: not a list of digests"),
    ("frame_inputs", {"x": {}}, "frame_inputs: not a list of digests per frame"),
    ("frame_inputs", {"2": {"transform": None}}, "frame_inputs: not a list of digests"),
])
def test_a_hand_edited_record_is_an_unreadable_manifest(cut, key, value, want):
    path = cut / "manifest.json"
    m = json.loads(path.read_text())
    m[key] = value
    path.write_text(json.dumps(m))
    with pytest.raises(errors.StateError, match=r"unreadable manifest \(" + want):
        run(snow(), cut, resume=True)


CAUSTICS = {"water": {"width": 24, "height": 20, "rain_rate": 80.0, "seed": 3},
            "light": {"light_direction": (0.3, 0.2, 1.0)}}


def caustics(**inputs):
    return get("caustics")(CAUSTICS, dict({"map_size": (48, 40)}, **inputs))


def test_caustics_ground_and_footprints(tmp_path):
    folder = tmp_path / "pool"
    run(caustics(), folder, end=4)
    ground = np.zeros((20, 24), np.float32)
    ground[5:9, 5:9] = -0.1  # a hole in the floor
    refused(caustics(ground=ground, level=0.5), folder, "ground: changed since the bake",
            end=4)
    print_ = np.zeros((20, 24), np.float32)
    print_[8:12, 8:12] = 0.05  # a floating object
    # Frame 1 has no footprint either way: the first frame pressed differs.
    refused(caustics(footprints={2: print_}), folder, "footprint at frame 2: changed since the "
            "bake", end=4)
    folder = tmp_path / "floating"
    run(caustics(footprints={2: print_}), folder, end=4)
    refused(caustics(footprints={3: print_}), folder,
            "footprint at frame 2: changed since the bake", end=4)
    assert run(caustics(footprints={2: print_}), folder, end=4, resume=True).resumed_from == 4


def test_rain_car_and_glass(tmp_path):
    small = {"rain": {"width": 32, "height": 32, "map_width": 64, "map_height": 64,
                      "cell_size": 0.002, "rain_rate": 3000.0, "seed": 5}}
    folder = tmp_path / "rain"
    run(get("rain")(small, {"car": {1: (10.0, 0.0), 3: (20.0, 1.0)}}), folder, end=4)
    refused(get("rain")(small, {"car": {1: (10.0, 0.0), 3: (25.0, 1.0)}}), folder,
            "car at frame 3: changed since the bake", end=4)
    mask = np.ones((32, 32), np.float32)
    mask[:, :4] = 0.0  # the glass a little narrower
    refused(get("rain")(small, {"car": {1: (10.0, 0.0), 3: (20.0, 1.0)}, "mask": mask}),
            folder, "glass: new since the bake", end=4)


GRID = {"source": "VELOCITY_GRID", "resolution": (8, 8, 8), "box_min": (0, 0, 0),
        "box_max": (1, 1, 1), "dt": 0.05, "reset_period": 0.0, "uvw_tile": 1.0}


def test_fluid_velocity_per_frame(tmp_path):
    vel = {f: (np.full((9, 9, 9, 3), 0.1 * f, np.float32), None) for f in (1, 2, 3)}
    folder = tmp_path / "fluid"
    run(get("fluid")({"fluid": GRID}, {"velocity": vel}), folder, end=3)
    faster = {**vel, 2: (vel[2][0] * 2, None)}
    refused(get("fluid")({"fluid": GRID}, {"velocity": faster}), folder,
            "velocity at frame 2: changed since the bake", end=3)


def test_a_mantaflow_frame_digest_is_its_files_bytes(tmp_path):
    """Not its path: a project moved with its cache resumes."""
    def cache(folder, speed):
        os.makedirs(os.path.dirname(mantaflow.data_path(str(folder), 1)), exist_ok=True)
        v = np.zeros((4, 4, 4, 3), np.float32)
        v[..., 2] = speed
        g = vdb.make_grid("velocity", v, voxel_size=0.25,
                          metadata={"file_base_resolution": (4, 4, 4)})
        vdb.write(mantaflow.data_path(str(folder), 1), [g])
        return mantaflow.CacheSource(str(folder), [1], (0, 0, 0), (1, 1, 1), (0, 0, 0),
                                     (1, 1, 1), (4, 4, 4))
    a = cache(tmp_path / "a", -2.0)
    moved = tmp_path / "moved"
    shutil.copytree(tmp_path / "a", moved)
    b = mantaflow.CacheSource(str(moved), [1], (0, 0, 0), (1, 1, 1), (0, 0, 0), (1, 1, 1),
                              (4, 4, 4))
    assert a.digest(1) == b.digest(1)
    assert cache(tmp_path / "c", -3.0).digest(1) != a.digest(1)
    turned = mantaflow.CacheSource(str(moved), [1], (0, 0, 0), (1, 1, 1), (0, 0, 0),
                                   (1, 1, 1), (4, 4, 4), time_scale=0.5)
    assert turned.digest(1) != a.digest(1)
    os.remove(mantaflow.data_path(str(moved), 1))
    assert b.digest(1) != a.digest(1)  # (a missing file: the step says what is wrong)


SPH = {"resolution": (16, 16, 16), "max_particles": 4000, "substeps": 4, "seed": 7}
STILL = [("box", (0.7, 0.15, 0.1), (0.1, 0.05, 0.1))]


def paddle(path):
    return get("fluid")({"fluid": SPH}, {"fill": ((0, 0, 0), (0.3, 0.3, 0.3)),
                                         "obstacles": STILL, "obstacle_path": path})


def test_fluid_moving_obstacles_per_frame(tmp_path):
    """Where the obstacles move to is recorded per frame: a resume keeps the frames whose path
    is unchanged and continues them to the same bytes, and refuses a path changed in them."""
    path = {f: [("box", (0.7 - 0.06 * f, 0.15, 0.1), (0.1, 0.05, 0.1))] for f in (2, 3, 4, 5, 6)}
    whole, cut = tmp_path / "whole", tmp_path / "cut"
    run(paddle(path), whole, end=6)
    run(paddle(path), cut, end=6, cancel_after=3)
    assert 3 <= run(paddle(path), cut, end=6, resume=True).resumed_from < 6
    assert snapshot(cut).keys() == snapshot(whole).keys()
    for f in range(1, 7):  # (a VDB file holds a fresh UUID: its grids' values are compared)
        name = f"surface_{f:04d}.npz"
        assert (cut / name).read_bytes() == (whole / name).read_bytes(), name
        name = f"fluid_{f:04d}.vdb"
        assert grid_values(cut / name) == grid_values(whole / name), name
    m = BakeCache(whole).read_manifest()
    placed = [m["frame_inputs"][str(f)]["obstacles"] for f in range(1, 7)]
    assert len(set(placed)) == 6
    refused(paddle({**path, 2: STILL}), whole, "obstacles at frame 2: changed since the bake",
            end=6)


def test_caustics_moving_ground(tmp_path):
    """A moving Ground's heights are recorded per frame: a resume with the floor moving
    otherwise over the kept frames is refused by the first such frame."""
    folder = tmp_path / "sinking"
    low = np.full((20, 24), -0.1, np.float32)
    run(caustics(ground_path={3: low}), folder, end=4)
    refused(caustics(ground_path={2: low}), folder, "ground at frame 2: changed since the bake",
            end=4)
    refused(caustics(), folder, "ground at frame 1: gone since the bake", end=4)
    assert run(caustics(ground_path={3: low}), folder, end=4, resume=True).resumed_from == 4
