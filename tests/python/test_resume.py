"""Resume: a cancelled or damaged bake continues from its last good checkpoint and ends
bit-identical to a bake that never stopped."""
import os
import shutil
import time

import pytest

from hydrobake.core import errors
from hydrobake.core.bake import BakeCache, BakeRunner
from hydrobake.core.effects import get

PARAMS = {"water": {"width": 40, "height": 32, "rain_rate": 80.0, "seed": 3},
          "light": {"light_direction": (0.3, 0.2, 1.0)}}
INPUTS = {"map_size": (80, 64)}


def effect(params=PARAMS):
    return get("caustics")(params, INPUTS)


def files(folder):
    return {n: (folder / n).read_bytes() for n in sorted(os.listdir(folder))
            if n.endswith(".exr")}


def bake_until_cancel(folder, frame):
    """Frames 1..12 into folder, cancelled after ``frame``."""
    e = effect()
    r = BakeRunner(e, folder, 1, 12, checkpoint_every=4,
                   on_frame=lambda s: s.frame == frame and r.cancel())
    with pytest.raises(errors.Cancelled):
        r.run()
    e.close()


def resume(folder):
    e = effect()
    r = BakeRunner(e, folder, 1, 12, checkpoint_every=4, resume=True)
    r.run()
    e.close()
    return r


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    folder = tmp_path_factory.mktemp("ref") / "bake"
    e = effect()
    BakeRunner(e, folder, 1, 12, checkpoint_every=4).run()
    e.close()
    return folder


def test_checkpoints_kept_every_n_frames_and_the_latest(reference):
    m = BakeCache(reference).read_manifest()
    assert sorted(map(int, m["checkpoints"])) == [1, 5, 9, 12]
    assert sorted(n for n in os.listdir(reference) if n.startswith("checkpoint")) == [
        "checkpoint_0001.bin", "checkpoint_0005.bin", "checkpoint_0009.bin",
        "checkpoint_0012.bin"]


def test_cancelled_bake_resumes_bit_identical(reference, tmp_path):
    folder = tmp_path / "bake"
    bake_until_cancel(folder, 7)
    assert BakeCache(folder).frames() == list(range(1, 8))
    r = resume(folder)
    assert r.resumed_from == 7 and r.state.status == "FINISHED"
    assert files(folder) == files(reference)
    assert BakeCache(folder).read_manifest()["complete"]


def test_a_damaged_frame_is_baked_again(reference, tmp_path):
    folder = tmp_path / "bake"
    shutil.copytree(reference, folder)
    damaged = folder / "caustics_0007.exr"
    damaged.write_bytes(damaged.read_bytes()[:-20] + b"\0" * 20)
    (folder / "water_0010.exr").unlink()
    r = resume(folder)
    assert r.resumed_from == 5  # the last checkpoint before the first bad frame
    assert files(folder) == files(reference)
    assert BakeCache(folder).verify() == []


def test_resume_extends_a_finished_bake(reference, tmp_path):
    folder = tmp_path / "bake"
    e = effect()
    BakeRunner(e, folder, 1, 9, checkpoint_every=4).run()
    e.close()
    r = resume(folder)
    assert r.resumed_from == 9 and files(folder) == files(reference)


def test_resume_refuses_changed_settings(reference, tmp_path):
    folder = tmp_path / "bake"
    shutil.copytree(reference, folder)
    changed = {"water": dict(PARAMS["water"], rain_rate=10.0), "light": PARAMS["light"]}
    e = effect(changed)
    # The message names the first parameter that differs, with both values.
    with pytest.raises(errors.StateError, match=r"^cannot resume the bake in .*: "
                       r"water\.rain_rate: 80\.0 in the bake, 10\.0 now; free it"):
        BakeRunner(e, folder, 1, 12, resume=True).run()
    e.close()
    assert files(folder) == files(reference)  # nothing was touched
    # A float32 parameter is shown as it was set (9.81), not as the manifest's double of it
    # (9.8100004196167).
    gravity = {"water": dict(PARAMS["water"], gravity=5.0), "light": PARAMS["light"]}
    e = effect(gravity)
    with pytest.raises(errors.StateError, match=r"water\.gravity: 9\.81 in the bake, 5\.0 now"):
        BakeRunner(e, folder, 1, 12, resume=True).run()
    e.close()


@pytest.mark.parametrize("inputs, want", [
    # The panel's Map Resolution: a map of another size from frame 13 on.
    ({"map_size": (40, 32)}, r"map_size: \[80, 64\] in the bake, \[40, 32\] now"),
    # The loop option: the last frames would cross-fade into another start.
    ({"loop": (1, 12, 3)}, r"loop: none in the bake, \[1, 12, 3\] now"),
    ({"level": 0.25}, r"level: 0\.5 in the bake, 0\.25 now"),
], ids=["map_size", "loop", "level"])
def test_resume_refuses_changed_inputs_beside_the_params(reference, tmp_path, inputs, want):
    folder = tmp_path / "bake"
    shutil.copytree(reference, folder)
    assert BakeCache(folder).read_manifest()["inputs"]["map_size"] == [80, 64]
    e = get("caustics")(PARAMS, dict(INPUTS, **inputs))
    with pytest.raises(errors.StateError, match=r"^cannot resume the bake in .*: " + want):
        BakeRunner(e, folder, 1, 12, resume=True).run()
    e.close()
    assert files(folder) == files(reference)  # nothing was touched


def test_resume_refuses_a_changed_rain_time_step(tmp_path):
    small = {"rain": {"width": 32, "height": 32, "map_width": 64, "map_height": 64,
                      "cell_size": 0.002, "rain_rate": 3000.0, "seed": 5}}
    folder = tmp_path / "rain"
    e = get("rain")(small, {"substeps": 2, "fps": 24.0})
    BakeRunner(e, folder, 1, 2).run()
    e.close()
    for inputs, want in (({"substeps": 3, "fps": 24.0}, "substeps: 2 in the bake, 3 now"),
                         ({"substeps": 2, "fps": 25.0}, "fps: 24.0 in the bake, 25.0 now")):
        e = get("rain")(small, inputs)
        with pytest.raises(errors.StateError, match=want):
            BakeRunner(e, folder, 1, 4, resume=True).run()
        e.close()
    e = get("rain")(small, {"substeps": 2, "fps": 24.0})  # the same: it continues
    r = BakeRunner(e, folder, 1, 4, resume=True)
    r.run()
    e.close()
    assert r.resumed_from == 2 and BakeCache(folder).frames() == [1, 2, 3, 4]


def test_free_removes_checkpoints_too(reference, tmp_path):
    folder = tmp_path / "bake"
    shutil.copytree(reference, folder)
    BakeCache(folder).free()
    assert not folder.exists()


def slow_checkpoints(e, seconds=0.2):
    """The effect with a state that takes `seconds` to save, as a large one does."""
    save = e.save_state
    e.saves = 0

    def slow():
        e.saves += 1
        time.sleep(seconds)
        return save()
    e.save_state = slow
    return e


def test_a_costly_checkpoint_is_written_less_often_and_on_cancel(reference, tmp_path):
    # Twelve quick frames, each checkpoint 0.2 s: writing every frame's would cost more than
    # a tenth of the bake, so only the kept intervals and the last are written.
    folder = tmp_path / "bake"
    e = slow_checkpoints(effect())
    BakeRunner(e, folder, 1, 12, checkpoint_every=4).run()
    e.close()
    assert e.saves < 8  # 4 due, and a few more only if the machine is slow
    assert sorted(map(int, BakeCache(folder).read_manifest()["checkpoints"])) == [1, 5, 9, 12]
    assert files(folder) == files(reference)
    # Cancelled between frames 7 and 8: frame 7's state is written before the bake stops, so
    # nothing baked is baked again.
    folder = tmp_path / "cut"
    e = slow_checkpoints(effect())
    r = BakeRunner(e, folder, 1, 12, checkpoint_every=4,
                   on_frame=lambda s: s.frame == 7 and r.cancel())
    with pytest.raises(errors.Cancelled):
        r.run()
    e.close()
    assert sorted(map(int, BakeCache(folder).read_manifest()["checkpoints"])) == [1, 5, 7]
    r = resume(folder)
    assert r.resumed_from == 7 and files(folder) == files(reference)


def test_resume_removes_what_the_killed_bake_was_writing(reference, tmp_path):
    folder = tmp_path / "bake"
    bake_until_cancel(folder, 7)
    # What a SIGKILL during frame 8 leaves: its files and checkpoint half written.
    left = [".caustics_0008.exr.tmp-4242-17", ".checkpoint_0008.bin.tmp-4242-18",
            ".manifest.json.tmp-4242-19"]
    for name in left + ["notes.txt", ".notes.txt.tmp-4242-20"]:
        (folder / name).write_bytes(b"partial")
    e = effect()
    BakeRunner(e, folder, 1, 12, checkpoint_every=4, resume=True).run()
    e.close()
    assert not any((folder / n).exists() for n in left)
    assert (folder / "notes.txt").exists() and (folder / ".notes.txt.tmp-4242-20").exists()
    assert files(folder) == files(reference)


def test_resume_never_shortens_a_bake(reference, tmp_path):
    """Resuming a 1-12 bake to frame 6 would drop six good frames: refused, nothing touched."""
    folder = tmp_path / "bake"
    shutil.copytree(reference, folder)
    before = {n: (folder / n).read_bytes() for n in os.listdir(folder)}
    e = effect()
    with pytest.raises(errors.StateError, match="to frame 6: it holds frames to 12"):
        BakeRunner(e, folder, 1, 6, checkpoint_every=4, resume=True).run()
    e.close()
    assert {n: (folder / n).read_bytes() for n in os.listdir(folder)} == before


def test_resume_of_a_complete_bake_steps_nothing(reference, tmp_path):
    folder = tmp_path / "bake"
    shutil.copytree(reference, folder)
    stamps = {n: os.stat(folder / n).st_mtime_ns for n in os.listdir(folder)
              if n != "manifest.json"}
    e = effect()
    stepped = []
    step = e.step
    e.step = lambda frame, progress: (stepped.append(frame), step(frame, progress))
    r = BakeRunner(e, folder, 1, 12, checkpoint_every=4, resume=True)
    r.run()
    e.close()
    assert stepped == [] and r.resumed_from == 12 and r.state.status == "FINISHED"
    assert BakeCache(folder).read_manifest()["complete"]
    assert {n: os.stat(folder / n).st_mtime_ns for n in stamps} == stamps


def test_the_time_left_after_a_resume_counts_only_this_runs_frames(reference, tmp_path):
    """Frames a resume found done took no time now: the estimate is per frame of this run."""
    folder = tmp_path / "bake"
    bake_until_cancel(folder, 6)
    e = effect()
    seen = []
    r = BakeRunner(e, folder, 1, 12, checkpoint_every=4, resume=True,
                   on_frame=lambda s: seen.append((s.done, s.resumed, s.eta(),
                                                   time.monotonic() - s.started)))
    r.run()
    e.close()
    done, resumed, eta, elapsed = seen[0]
    assert resumed >= 5 and done == resumed + 1  # one frame baked by this run
    # (counting the resumed frames as well would make it about 1/7 of this)
    assert eta == pytest.approx(elapsed / (done - resumed) * (12 - done), rel=0.2)


def test_snow_resumed_between_given_transforms_is_bit_identical(tmp_path):
    """A transform holds from its frame until the next one given. A checkpoint holds no mesh:
    resumed after frame 5, the snow stepped frames 6-8 with the mesh at rest, not moved as
    frame 3 had moved it."""
    import numpy as np

    from test_snow_binding import box_with_roof
    pos, tris, uvs, mi = box_with_roof()
    moved = np.eye(4)
    moved[0, 3], moved[2, 3] = 0.7, -0.3

    def snow():
        return get("snow")({"snow": {"flake_count": 5000, "texture_width": 32,
                                     "texture_height": 32, "wind": (1, 0, 0),
                                     "flake_radius": 0.01}},
                           {"positions": pos, "triangles": tris, "uvs": uvs,
                            "material_index": mi, "substeps": 4, "transforms": {3: moved},
                            "materials": [(0.4, False, False), (0.0, False, True)]})

    def exrs(folder):
        return {n: (folder / n).read_bytes() for n in sorted(os.listdir(folder))
                if n.endswith(".exr")}
    ref, cut = tmp_path / "ref", tmp_path / "cut"
    e = snow()
    BakeRunner(e, ref, 1, 8, checkpoint_every=3).run()
    e.close()
    e = snow()
    r = BakeRunner(e, cut, 1, 8, checkpoint_every=3,
                   on_frame=lambda s: s.written == 5 and r.cancel())
    with pytest.raises(errors.Cancelled):
        r.run()
    e.close()
    e = snow()
    r = BakeRunner(e, cut, 1, 8, checkpoint_every=3, resume=True)
    r.run()
    e.close()
    assert r.resumed_from == 5 and exrs(cut) == exrs(ref)


def test_a_refusal_shows_values_as_set_and_any_number_quietly():
    """float32 parameters as the artist typed them; a manifest number past float32 (edited
    by hand) as it is, with no overflow warning from the conversion (a manifest fuzz)."""
    import warnings
    from hydrobake.core.bake.runner import _show
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert _show(9.8100004196167) == "9.81"
        assert _show([1e308, -1e39, 2.5]) == "[1e+308, -1e+39, 2.5]"
        assert _show(None) == "none" and _show("x") == "x"
