"""Frames written beside the next step (effects with detached_outputs): the same files and
manifest as one frame at a time, frames recorded in order, and nothing lost when the bake is
cancelled or a write fails while the next frame is being stepped."""
import os
import threading

import pytest

from hydrobake.core import errors
from hydrobake.core.bake import BakeCache, BakeRunner, runner as runner_mod
from fixture_effect import WaveEffect

WAIT = 10.0  # s; only a broken runner waits this long


class Detached(WaveEffect):
    """WaveEffect whose frames may be written while the next one is stepped, with a state
    (its frame) so that checkpoints can be checked, and a record of where things ran."""
    detached_outputs = True

    def __init__(self, **kw):
        super().__init__(**kw)
        self.saved_on = set()
        self.step_started = {}  # frame -> Event

    def step(self, frame, progress):
        self.step_started.setdefault(frame, threading.Event()).set()
        super().step(frame, progress)

    def save_state(self):
        self.saved_on.add(threading.current_thread().name)
        return str(self.t).encode()

    def load_state(self, data):
        self.t = int(data)


def listing(folder):
    return sorted(n for n in os.listdir(folder))


def test_the_files_are_those_of_a_bake_one_frame_at_a_time(tmp_path):
    plain, piped = tmp_path / "plain", tmp_path / "piped"
    BakeRunner(WaveEffect(), plain, 1, 6).run()
    e = Detached()
    seen = []
    r = BakeRunner(e, piped, 1, 6, checkpoint_every=2, on_frame=lambda s: seen.append(s.written))
    r.run()
    assert r.state.status == "FINISHED" and seen == [1, 2, 3, 4, 5, 6]
    for i in range(1, 7):
        name = f"wave_{i:04d}.exr"
        assert (piped / name).read_bytes() == (plain / name).read_bytes()
    m = BakeCache(piped).read_manifest()
    assert m["complete"] and sorted(map(int, m["frames"])) == list(range(1, 7))
    assert BakeCache(piped).verify() == []
    # Each checkpoint holds its own frame's state, taken on the bake's thread before the
    # next step changed it (the files of that frame were still being written).
    for f, entry in m["checkpoints"].items():
        assert (piped / entry["file"]).read_bytes() == f.encode()
    assert not any(n.startswith("hydrobake-write") for n in e.saved_on)
    assert not [n for n in listing(piped) if ".tmp" in n]


def test_a_frame_is_written_while_the_next_is_stepped(tmp_path, monkeypatch):
    # The write of frame 2 waits until frame 3's step has begun: one frame at a time, it
    # would wait in vain.
    e = Detached()
    overlapped = {}
    write = runner_mod.write_output

    def waiting_write(folder, stream, frame, output, tag=""):
        nxt = e.step_started.setdefault(frame + 1, threading.Event())
        if frame == 2:
            overlapped[frame] = nxt.wait(WAIT)
        return write(folder, stream, frame, output, tag)
    monkeypatch.setattr(runner_mod, "write_output", waiting_write)
    BakeRunner(e, tmp_path / "bake", 1, 4).run()
    assert overlapped == {2: True}
    assert BakeCache(tmp_path / "bake").frames() == [1, 2, 3, 4]


def test_cancel_during_the_next_step_keeps_the_frame_being_written(tmp_path):
    folder = tmp_path / "bake"
    e = Detached(delay=0.2)
    r = BakeRunner(e, folder, 1, 20, checkpoint_every=4)
    r.start()
    assert e.step_started.setdefault(4, threading.Event()).wait(WAIT)
    r.cancel()  # inside step 4, while frame 3 is written or just recorded
    assert r.join(WAIT)
    assert r.state.status == "CANCELLED"
    assert BakeCache(folder).frames() == [1, 2, 3]
    assert BakeCache(folder).verify() == []
    assert not [n for n in listing(folder) if ".tmp" in n]
    # and the bake resumes from its checkpoint to the same files as an unbroken one
    e2 = Detached()
    r2 = BakeRunner(e2, folder, 1, 6, checkpoint_every=4, resume=True)
    r2.run()
    # from frame 3's checkpoint when checkpoints are cheap (the latest is then written every
    # frame), or from frame 1's, a kept one
    assert 1 <= r2.resumed_from <= 3 and r2.state.status == "FINISHED"
    ref = tmp_path / "ref"
    BakeRunner(Detached(), ref, 1, 6, checkpoint_every=4).run()
    for i in range(1, 7):
        name = f"wave_{i:04d}.exr"
        assert (folder / name).read_bytes() == (ref / name).read_bytes()


def test_a_write_that_fails_stops_the_bake_with_its_error(tmp_path, monkeypatch):
    write = runner_mod.write_output

    def failing(folder, stream, frame, output, tag=""):
        if frame == 3:
            raise OSError(28, "No space left on device")
        return write(folder, stream, frame, output, tag)
    monkeypatch.setattr(runner_mod, "write_output", failing)
    folder = tmp_path / "bake"
    r = BakeRunner(Detached(), folder, 1, 6)
    with pytest.raises(OSError, match="No space left"):
        r.run()
    assert r.state.status == "FAILED" and "No space left" in r.state.message
    assert BakeCache(folder).frames() == [1, 2]
    assert not [n for n in listing(folder) if ".tmp" in n or n == "wave_0003.exr"]


def test_a_step_that_fails_still_records_the_frame_before(tmp_path):
    folder = tmp_path / "bake"
    r = BakeRunner(Detached(fail_at=4), folder, 1, 6)
    with pytest.raises(errors.InvalidArgument, match="frame = 4"):
        r.run()
    assert r.state.status == "FAILED" and BakeCache(folder).frames() == [1, 2, 3]
    assert BakeCache(folder).verify() == []


def test_cancelled_between_frames_the_last_frame_and_its_state_are_written(tmp_path):
    # A state that takes 0.2 s to save is not written every frame (see test_resume); cancelled
    # between frames, the bake first records the frame in flight, then writes the state of
    # the last frame it stepped, so a resume bakes nothing twice.
    import time

    class Slow(Detached):
        def save_state(self):
            time.sleep(0.2)
            return super().save_state()

    folder = tmp_path / "bake"
    r = BakeRunner(Slow(), folder, 1, 12, checkpoint_every=4,
                   on_frame=lambda s: s.written == 6 and r.cancel())
    with pytest.raises(errors.Cancelled):
        r.run()
    frames = BakeCache(folder).frames()
    m = BakeCache(folder).read_manifest()
    assert frames == list(range(1, len(frames) + 1)) and len(frames) >= 6
    assert max(map(int, m["checkpoints"])) == frames[-1]
    r2 = BakeRunner(Detached(), folder, 1, 12, checkpoint_every=4, resume=True)
    r2.run()
    assert r2.resumed_from == frames[-1]
    ref = tmp_path / "ref"
    BakeRunner(Detached(), ref, 1, 12, checkpoint_every=4).run()
    for i in range(1, 13):
        name = f"wave_{i:04d}.exr"
        assert (folder / name).read_bytes() == (ref / name).read_bytes()


def test_progress_counts_the_frames_already_stepped(tmp_path):
    # While frame 3 is stepped, frame 2 may still be being written: the bar stands at two
    # frames of five, not at the one recorded.
    release = threading.Event()

    class Held(Detached):
        def step(self, frame, progress):
            super().step(frame, progress)
            if frame == 3:
                assert release.wait(WAIT)

    e = Held()
    r = BakeRunner(e, tmp_path / "bake", 1, 5)
    r.start()
    try:
        assert e.step_started.setdefault(3, threading.Event()).wait(WAIT)
        assert r.poll_fraction() == pytest.approx(2 / 5)
    finally:
        release.set()
        assert r.join(WAIT)
    assert r.state.status == "FINISHED" and r.poll_fraction() == 1.0
