"""The bake's folder against what else may happen to it: a second bake or a free in it at the
same time, a manifest edited by hand or not ours, a file where the folder should be."""
import json
import os
import subprocess
import sys
import threading

import pytest

from hydrobake.core import errors
from hydrobake.core.bake import BakeCache, BakeRunner, cache
from fixture_effect import WaveEffect

HERE = os.path.dirname(os.path.abspath(__file__))
ADDON = os.path.join(os.path.dirname(os.path.dirname(HERE)), "blender_addon")
WAIT = 10.0


def snapshot(folder):
    return {n: (folder / n).read_bytes() for n in sorted(os.listdir(folder))}


# --- two at once ----------------------------------------------------------------------------

def running(folder, frames=40):
    """A bake into ``folder`` running in a thread, two frames in."""
    r = BakeRunner(WaveEffect(delay=0.05), folder, 1, frames)
    r.start()
    while r.state.done < 2:
        assert r.is_alive(), r.state.message
        threading.Event().wait(0.01)
    return r


def test_a_second_bake_into_the_folder_is_refused_and_the_first_finishes(tmp_path):
    # The second bake began by freeing the folder: the first's frames and the temporaries it
    # was writing went, and it failed ("cannot rename the temporary file over it") or left a
    # manifest of the other's.
    folder = tmp_path / "bake"
    first = running(folder, 20)
    for resume in (False, True):
        second = BakeRunner(WaveEffect(), folder, 1, 5, resume=resume)
        with pytest.raises(errors.FileIOError, match="another bake or free is working in"):
            second.run()
        assert second.state.status == "FAILED"
    assert first.join(WAIT) and first.state.status == "FINISHED", first.state.message
    c = BakeCache(folder)
    assert c.frames() == list(range(1, 21)) and c.verify() == []
    assert c.read_manifest()["complete"]
    assert sorted(os.listdir(folder)) == ["manifest.json"] + [f"wave_{i:04d}.exr"
                                                              for i in range(1, 21)]


def test_a_bake_in_another_process_is_refused_too(tmp_path):
    folder = tmp_path / "bake"
    first = running(folder, 20)
    code = (f"import sys; sys.path[:0] = [{ADDON!r}, {HERE!r}]\n"
            "from hydrobake.core.bake import BakeRunner\n"
            "from fixture_effect import WaveEffect\n"
            f"BakeRunner(WaveEffect(), {str(folder)!r}, 1, 3).run()\n")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                       timeout=60)
    assert r.returncode == 1 and "another bake or free is working in" in r.stderr
    assert first.join(WAIT) and first.state.status == "FINISHED", first.state.message
    assert BakeCache(folder).frames() == list(range(1, 21))
    assert BakeCache(folder).verify() == []


def test_a_free_during_a_bake_is_refused(tmp_path):
    folder = tmp_path / "bake"
    first = running(folder, 12)
    with pytest.raises(errors.FileIOError, match="another bake or free is working in"):
        BakeCache(folder).free()
    assert first.join(WAIT) and first.state.status == "FINISHED", first.state.message
    assert BakeCache(folder).frames() == list(range(1, 13))
    BakeCache(folder).free()  # once it is done
    assert not folder.exists()


def test_the_lock_of_a_killed_bake_stops_nothing(tmp_path):
    # What SIGKILL leaves: the lock file, which no process holds any more.
    folder = tmp_path / "bake"
    BakeRunner(WaveEffect(), folder, 1, 3).run()
    (folder / cache.LOCK).write_bytes(b"")
    r = BakeRunner(WaveEffect(), folder, 1, 5, resume=True)
    r.run()
    assert r.resumed_from == 3 and BakeCache(folder).frames() == [1, 2, 3, 4, 5]
    assert cache.LOCK not in os.listdir(folder)
    (folder / cache.LOCK).write_bytes(b"")
    BakeCache(folder).free()
    assert not folder.exists()


# --- a manifest edited by hand ----------------------------------------------------------------

def test_a_manifest_naming_files_outside_the_folder_frees_nothing_there(tmp_path):
    # Free removed every file the manifest listed: "../precious.txt" too.
    folder = tmp_path / "bake"
    BakeRunner(WaveEffect(), folder, 1, 2).run()
    (tmp_path / "precious.txt").write_text("mine")
    (tmp_path / "checkpoint_0001.bin").write_text("mine too")
    m = json.loads((folder / "manifest.json").read_text())
    m["frames"]["1"]["../precious.txt"] = "0" * 64
    m["checkpoints"] = {"1": {"file": "../checkpoint_0001.bin", "sha256": "0" * 64}}
    (folder / "manifest.json").write_text(json.dumps(m))
    with pytest.raises(ValueError, match="unreadable manifest"):
        BakeCache(folder).read_manifest()
    BakeCache(folder).free()
    assert (tmp_path / "precious.txt").read_text() == "mine"
    assert (tmp_path / "checkpoint_0001.bin").read_text() == "mine too"


def _no_frames(m):
    del m["frames"]


def _frame_key(m):
    m["frames"]["x"] = {}


def _frame_null(m):
    m["frames"]["1"] = None


def _other_file(m):
    m["frames"]["1"]["notes.txt"] = "0" * 64  # free removed it


def _checkpoint_path(m):
    m["checkpoints"]["1"]["file"] = "/etc/passwd"


def _checkpoint_a_frame(m):
    m["checkpoints"]["1"]["file"] = "wave_0002.exr"  # a frame is not a checkpoint


@pytest.mark.parametrize("edit, why", [
    (_no_frames, "no frame list"),
    (_frame_key, "frame 'x' is not a frame number"),
    (_frame_null, "frame 1: not a list of files"),
    (_other_file, "frame 1: file 'notes.txt' is not a file of the bake"),
    (_checkpoint_path, "checkpoint '1': not a checkpoint of the bake"),
    (_checkpoint_a_frame, "checkpoint '1': not a checkpoint of the bake"),
    (lambda m: [m], "manifest format 'list'"),
], ids=["no-frames", "frame-key", "frame-null", "other-file", "checkpoint-path",
         "checkpoint-frame", "list"])
def test_a_manifest_of_the_wrong_shape_is_refused_by_name(tmp_path, edit, why):
    # It failed with KeyError 'frames', "invalid literal for int()", "'list' object has no
    # attribute 'get'" or "'NoneType' object is not iterable", from inside the runner.
    folder = tmp_path / "bake"
    BakeRunner(Detached(), folder, 1, 3).run()
    m = json.loads((folder / "manifest.json").read_text())
    m = edit(m) or m
    (folder / "manifest.json").write_text(json.dumps(m))
    before = snapshot(folder)
    r = BakeRunner(Detached(), folder, 1, 5, resume=True)
    # A StateError, as a resume's other refusals (the addon's bake reported it as a bug).
    with pytest.raises(errors.StateError, match=r"^cannot resume: .*manifest\.json: "
                       r"(unreadable manifest \()?" +
                       why.replace("(", r"\(").replace(")", r"\)")):
        r.run()
    assert snapshot(folder) == before  # nothing touched
    r = BakeRunner(Detached(), folder, 1, 5)  # a fresh bake replaces it
    r.run()
    assert BakeCache(folder).frames() == [1, 2, 3, 4, 5] and BakeCache(folder).verify() == []


class Detached(WaveEffect):
    """WaveEffect with a state, so that its manifest lists checkpoints."""

    def save_state(self):
        return str(self.t).encode()

    def load_state(self, data):
        self.t = int(data)


# --- a file where the folder should be ----------------------------------------------------------

def test_a_file_where_the_folder_should_be_is_named(tmp_path):
    (tmp_path / "bake").write_text("not a folder")
    with pytest.raises(errors.FileIOError, match="bake: is a file, not a folder"):
        BakeRunner(WaveEffect(), tmp_path / "bake", 1, 2).run()
    assert (tmp_path / "bake").read_text() == "not a folder"
