"""The bake framework from plain Python: manifest, checksums, atomic frames, cancel, free."""
import json
import os
import threading
import time

import pytest

from hydrobake.core import errors, exr
from hydrobake.core.bake import BakeCache, BakeRunner, cache
from fixture_effect import WaveEffect


def test_bake_writes_frames_and_manifest(tmp_path):
    folder = tmp_path / "bake"
    r = BakeRunner(WaveEffect(), folder, 3, 6, header={"object": "Plane"})
    r.run()
    assert r.state.status == "FINISHED" and r.state.done == 4
    m = json.loads((folder / "manifest.json").read_text())
    assert m["complete"] is True and m["frame_start"] == 3 and m["frame_end"] == 6
    assert m["effect"] == "testwave" and m["params"] == {"size": 32} and m["object"] == "Plane"
    assert sorted(m["frames"]) == ["3", "4", "5", "6"]
    for frame, files in m["frames"].items():
        assert list(files) == [f"wave_{int(frame):04d}.exr"]
        for name, digest in files.items():
            assert cache.file_checksum(folder / name) == digest
    assert sorted(os.listdir(folder)) == ["manifest.json"] + [f"wave_000{i}.exr" for i in
                                                              range(3, 7)]
    assert BakeCache(folder).verify() == []
    assert exr.Reader(folder / "wave_0004.exr").channels.keys() == {"B", "G", "R", "height"}


def test_same_inputs_same_bytes(tmp_path):
    for name in ("a", "b"):
        BakeRunner(WaveEffect(), tmp_path / name, 1, 3).run()
    for i in (1, 2, 3):
        assert (tmp_path / "a" / f"wave_000{i}.exr").read_bytes() == \
            (tmp_path / "b" / f"wave_000{i}.exr").read_bytes()


def test_cancel_midway_keeps_earlier_frames_and_no_partial_file(tmp_path):
    folder = tmp_path / "bake"
    r = BakeRunner(WaveEffect(delay=0.15), folder, 1, 40)
    r.start()
    while r.state.done < 3:
        time.sleep(0.01)
    t0 = time.monotonic()
    r.cancel()
    assert r.join(5.0)
    # Within about a frame (0.15 s; loose for a busy machine): the rest would take 5 s.
    assert time.monotonic() - t0 < 2.0
    assert r.state.status == "CANCELLED"
    m = BakeCache(folder).read_manifest()
    assert m["complete"] is False
    done = sorted(int(f) for f in m["frames"])
    assert done == list(range(1, len(done) + 1)) and len(done) >= 3
    on_disk = sorted(os.listdir(folder))
    assert on_disk == ["manifest.json"] + [f"wave_{i:04d}.exr" for i in done]
    assert BakeCache(folder).verify() == []


def test_cancelled_before_it_starts_leaves_the_earlier_bake_alone(tmp_path):
    # A command line interrupted while the next bake was being set up.
    folder = tmp_path / "bake"
    BakeRunner(WaveEffect(), folder, 1, 3).run()
    before = {n: (folder / n).read_bytes() for n in os.listdir(folder)}
    r = BakeRunner(WaveEffect(), folder, 1, 5)
    r.cancel()
    with pytest.raises(errors.Cancelled, match="before it started"):
        r.run()
    assert r.state.status == "CANCELLED" and r.state.done == 0
    assert {n: (folder / n).read_bytes() for n in os.listdir(folder)} == before


def test_failure_keeps_earlier_frames_and_reports(tmp_path):
    folder = tmp_path / "bake"
    r = BakeRunner(WaveEffect(fail_at=3), folder, 1, 5)
    with pytest.raises(errors.InvalidArgument, match="frame = 3"):
        r.run()
    assert r.state.status == "FAILED" and "frame = 3" in r.state.message
    assert BakeCache(folder).frames() == [1, 2]


def test_verify_finds_a_damaged_frame(tmp_path):
    folder = tmp_path / "bake"
    BakeRunner(WaveEffect(), folder, 1, 3).run()
    p = folder / "wave_0002.exr"
    data = bytearray(p.read_bytes())
    data[-10] ^= 0xFF
    p.write_bytes(bytes(data))
    assert BakeCache(folder).verify() == [2]
    (folder / "wave_0003.exr").unlink()
    assert BakeCache(folder).verify() == [2, 3]


def test_free_removes_the_bake_and_nothing_else(tmp_path):
    folder = tmp_path / "bake"
    BakeRunner(WaveEffect(), folder, 1, 3).run()
    (folder / "notes.txt").write_text("mine")
    (folder / ".wave_0004.exr.tmp-123-4").write_bytes(b"partial")  # left by a crash
    removed = BakeCache(folder).free()
    assert sorted(removed) == sorted(["manifest.json", ".wave_0004.exr.tmp-123-4"] +
                                     [f"wave_000{i}.exr" for i in (1, 2, 3)])
    assert os.listdir(folder) == ["notes.txt"]
    (folder / "notes.txt").unlink()
    BakeRunner(WaveEffect(), folder, 1, 1).run()
    BakeCache(folder).free()
    assert not folder.exists()  # an emptied folder goes too


def test_rebake_replaces_the_old_bake(tmp_path):
    folder = tmp_path / "bake"
    BakeRunner(WaveEffect(), folder, 1, 5).run()
    BakeRunner(WaveEffect(), folder, 1, 2).run()
    assert BakeCache(folder).frames() == [1, 2]
    assert not (folder / "wave_0005.exr").exists()


def test_bad_frame_range_is_refused(tmp_path):
    with pytest.raises(errors.InvalidArgument, match="frame_end = 1: must be >= frame_start = 2"):
        BakeRunner(WaveEffect(), tmp_path, 2, 1)
    with pytest.raises(errors.InvalidArgument, match="frame_start = -1"):
        BakeRunner(WaveEffect(), tmp_path, -1, 1)


def test_atomic_path_removes_the_temporary_on_error(tmp_path):
    target = tmp_path / "f.bin"
    target.write_bytes(b"old")
    with pytest.raises(RuntimeError):
        with cache.atomic_path(str(target)) as tmp:
            open(tmp, "wb").write(b"half")
            raise RuntimeError("crash")
    assert target.read_bytes() == b"old" and os.listdir(tmp_path) == ["f.bin"]


def test_npz_bytes_do_not_depend_on_when_they_are_written(tmp_path, monkeypatch):
    import time

    import numpy as np

    from hydrobake.core.bake.runner import write_npz
    arrays = {"positions": np.arange(12, dtype=np.float32).reshape(4, 3),
              "triangles": np.array([[0, 1, 2], [0, 2, 3]], np.int32)}
    write_npz(str(tmp_path / "a.npz"), arrays)
    later = time.time() + 3600.0
    monkeypatch.setattr(time, "time", lambda: later)
    monkeypatch.setattr(time, "localtime", lambda t=None: time.gmtime(later))
    write_npz(str(tmp_path / "b.npz"), arrays)
    assert (tmp_path / "a.npz").read_bytes() == (tmp_path / "b.npz").read_bytes()
    back = np.load(str(tmp_path / "b.npz"))
    assert set(back.files) == set(arrays)
    for k, v in arrays.items():
        np.testing.assert_array_equal(back[k], v)


def test_a_file_tag_begins_every_frame_file_and_is_recorded(tmp_path):
    folder = tmp_path / "bake"
    BakeRunner(WaveEffect(), folder, 1, 2, header={"file_tag": "shot_Plane_testwave_"}).run()
    m = BakeCache(folder).read_manifest()
    assert m["file_tag"] == "shot_Plane_testwave_"
    assert sorted(os.listdir(folder)) == sorted(["manifest.json"] + [
        f"shot_Plane_testwave_wave_000{i}.exr" for i in (1, 2)])
    assert cache.stream_stem(m, "wave") == "shot_Plane_testwave_wave"
    assert cache.stem_in(folder, "wave") == "shot_Plane_testwave_wave"
    assert cache.untagged(m, "shot_Plane_testwave_wave_0002.exr") == "wave_0002.exr"
    assert BakeCache(folder).verify() == []
    # A bake from before tags: its names are the streams' own.
    BakeRunner(WaveEffect(), tmp_path / "old", 1, 1).run()
    assert cache.stem_in(tmp_path / "old", "wave") == "wave"
    assert cache.stem_in(tmp_path / "none", "wave") == "wave"


def test_a_resume_keeps_the_tag_its_bake_began_with(tmp_path):
    folder = tmp_path / "bake"
    r = BakeRunner(WaveEffect(), folder, 1, 4, header={"file_tag": "a_"})
    r.run()
    m = BakeCache(folder).read_manifest()
    del m["frames"]["4"]  # as if killed before frame 4 was recorded
    m["complete"] = False
    BakeCache(folder).write_manifest(m)
    os.remove(folder / "a_wave_0004.exr")
    BakeRunner(WaveEffect(), folder, 1, 4, header={"file_tag": "b_"}, resume=True).run()
    m = BakeCache(folder).read_manifest()
    assert m["file_tag"] == "a_" and m["complete"]
    assert sorted(os.listdir(folder)) == sorted(["manifest.json"] + [f"a_wave_000{i}.exr"
                                                                     for i in range(1, 5)])


@pytest.mark.parametrize("tag", [".hidden_", "sub/dir_", 7])
def test_a_bad_file_tag_is_refused_by_name(tmp_path, tag):
    with pytest.raises(errors.InvalidArgument, match="file_tag"):
        BakeRunner(WaveEffect(), tmp_path / "bake", 1, 1, header={"file_tag": tag})
    assert not (tmp_path / "bake").exists()


def test_a_manifest_whose_tag_is_a_path_is_not_acted_on(tmp_path):
    folder = tmp_path / "bake"
    BakeRunner(WaveEffect(), folder, 1, 1, header={"file_tag": "a_"}).run()
    m = json.loads((folder / "manifest.json").read_text())
    m["file_tag"] = "../a_"
    (folder / "manifest.json").write_text(json.dumps(m))
    with pytest.raises(ValueError, match="file_tag"):
        BakeCache(folder).read_manifest()
