"""A full disk (or a file size limit) while baking: the error names the file, nothing cut is
renamed into place or recorded, and the frames before stay recorded and whole.

A file size limit (RLIMIT_FSIZE, SIGXFSZ ignored) fails writes as a full disk does, without
needing a small file system: each case runs in a child process that sets it."""
import os
import subprocess
import sys
import textwrap

import numpy as np

from hydrobake.core import errors, vdb
from hydrobake.core.bake import BakeCache, BakeRunner, cache
from hydrobake.core.bake import runner as runner_mod
from hydrobake.core.effects.base import Effect

HERE = os.path.dirname(os.path.abspath(__file__))
ADDON = os.path.join(os.path.dirname(os.path.dirname(HERE)), "blender_addon")


class Volume(Effect):
    """A volume that grows with the frame (frame f: (8f)^3 random voxels, so frame 3 is
    about 55 kB and frames 1 and 2 are under 40 kB), a small EXR and a small state."""
    name = "testvolume"
    streams = ("vol", "wave")

    def __init__(self, state_bytes=16):
        super().__init__()
        self.t, self.state_bytes = 0, state_bytes

    def params_dict(self):
        return {}

    def step(self, frame, progress):
        self.t = frame

    def outputs(self, frame):
        n = 8 * frame
        a = np.random.default_rng(frame).random((n, n, n), dtype=np.float32)
        return {"vol": ("vdb", [dict(name="density", array=a)], {}),
                "wave": ("exr", {"Y": np.full((4, 4), frame, np.float32)}, {})}

    def save_state(self):
        return self.t.to_bytes(4, "little") * (self.state_bytes // 4)

    def load_state(self, data):
        self.t = int.from_bytes(data[:4], "little")


def run_limited(code, limit=40000):
    """Runs ``code`` in a child whose files may not grow past ``limit`` bytes; returns its
    stdout (the child prints what the parent checks)."""
    prelude = textwrap.dedent(f"""
        import resource, signal, sys
        sys.path[:0] = [{ADDON!r}, {HERE!r}]
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)  # a failed write, not a dead process
        resource.setrlimit(resource.RLIMIT_FSIZE, ({limit}, resource.RLIM_INFINITY))
        """)
    r = subprocess.run([sys.executable, "-c", prelude + textwrap.dedent(code)],
                       capture_output=True, text=True, timeout=120,
                       env=dict(os.environ, PYTHONDONTWRITEBYTECODE="1"))
    assert r.returncode == 0, r.stderr
    return r.stdout


def test_a_vdb_cut_short_is_an_error_and_never_renamed_into_place(tmp_path):
    # OpenVDB's writer ignores failed writes: the cut file was renamed over the target and
    # the bake recorded it as a good frame.
    out = run_limited(f"""
        import numpy as np
        from hydrobake.core import errors, vdb
        a = np.random.default_rng(1).random((40, 40, 40), dtype=np.float32)
        try:
            vdb.write({str(tmp_path / "big.vdb")!r}, [dict(name="density", array=a)])
            print("written")
        except errors.FileIOError as exc:
            print("error:", exc)
        """)
    assert out.startswith("error: ") and "big.vdb" in out and "written whole" in out
    assert os.listdir(tmp_path) == []  # neither the file nor its temporary


def test_a_bake_whose_volume_does_not_fit_keeps_the_frames_before(tmp_path):
    folder = tmp_path / "bake"
    out = run_limited(f"""
        from hydrobake.core.bake import BakeRunner
        from test_durability_full_disk import Volume
        r = BakeRunner(Volume(), {str(folder)!r}, 1, 5)
        try:
            r.run()
        except OSError:
            pass
        print(r.state.status, r.state.message)
        """)
    assert out.startswith("FAILED ") and "vol_0003.vdb" in out and "written whole" in out
    c = BakeCache(folder)
    assert c.frames() == [1, 2] and c.verify() == []
    for f in (1, 2):
        assert vdb.read_grid(str(folder / f"vol_{f:04d}.vdb"), "density").shape == (8 * f,) * 3
    assert not (folder / "vol_0003.vdb").exists()
    assert not [n for n in os.listdir(folder) if n.startswith(".")]  # no temporary, no lock
    # With room again, a resume finishes it.
    r = BakeRunner(Volume(), folder, 1, 5, resume=True)
    r.run()
    assert r.resumed_from in (1, 2) and c.frames() == [1, 2, 3, 4, 5] and c.verify() == []


def test_a_full_disk_error_names_the_file(tmp_path):
    # A checkpoint past the limit: Python's bare "[Errno 27] File too large" said which file
    # only to a debugger.
    folder = tmp_path / "bake"
    out = run_limited(f"""
        from hydrobake.core.bake import BakeRunner
        from test_durability_full_disk import Volume
        r = BakeRunner(Volume(state_bytes=80000), {str(folder)!r}, 1, 1)
        try:
            r.run()
        except OSError as exc:
            print(type(exc).__name__, exc)
        """)
    assert out.startswith("FileIOError ") and "checkpoint_0001.bin" in out, out
    assert "File too large" in out
    assert BakeCache(folder).frames() == []
    assert not [n for n in os.listdir(folder) if n.startswith(".")]


def test_every_file_is_flushed_to_the_disk_before_its_rename(tmp_path, monkeypatch):
    # The EXR writer and the checkpoints were; the npz and VDB files were renamed into place
    # straight from the page cache (a power cut could leave an empty frame under its name).
    synced = []
    fsync = os.fsync

    def recording(fd):
        synced.append(os.readlink(f"/proc/self/fd/{fd}"))
        return fsync(fd)
    monkeypatch.setattr(os, "fsync", recording)
    runner_mod.write_output(str(tmp_path), "pts", 1,
                            ("npz", {"positions": np.zeros((3, 3), np.float32)}, {}))
    runner_mod.write_output(str(tmp_path), "vol", 1,
                            ("vdb", [dict(name="density", array=np.ones((4, 4, 4)))], {}))
    assert sorted(os.listdir(tmp_path)) == ["pts_0001.npz", "vol_0001.vdb"]
    assert any(os.path.basename(p).startswith(".pts_0001.npz.tmp-") for p in synced)
    assert any(os.path.basename(p).startswith(".vol_0001.vdb.tmp-") for p in synced)
    # ... and the folder after the renames, so that they outlive a power cut too.
    last = max(i for i, p in enumerate(synced) if os.path.basename(p).startswith(".vol_"))
    assert str(tmp_path) in synced[last + 1:], synced


def test_the_first_error_is_the_one_raised(tmp_path):
    # A folder under a file: removing the temporary failed too, and that error (Not a
    # directory) hid the writer's own.
    (tmp_path / "f").write_bytes(b"")
    try:
        cache.write_bytes_atomic(str(tmp_path / "f" / "x.bin"), b"data")
    except errors.FileIOError as exc:
        assert str(exc).startswith(f'"{tmp_path / "f" / "x.bin"}": cannot write it: ')
    else:
        raise AssertionError("no error")
