"""The frame loop every bake runs, in a worker thread (Blender UI) or blocking (background).

An effect (see core/effects/base.py) advances one frame per ``step`` and hands back its
outputs; the runner names, writes and records them. Cancel is honoured between frames and,
through the shared hbk_progress_t, inside long C calls.
"""
import os
import threading
import time

from .. import _lib, errors, exr
from . import cache as cache_mod


class BakeState:
    """What a UI needs to show; written by the runner, read by anyone."""

    def __init__(self, frame_start, frame_end):
        self.frame_start, self.frame_end = frame_start, frame_end
        self.frame = None          # frame being baked
        self.done = 0              # frames finished
        self.fraction = 0.0        # 0..1 over the whole bake
        self.status = "PENDING"    # PENDING RUNNING FINISHED CANCELLED FAILED
        self.message = ""
        self.started = None
        self.ended = None

    @property
    def total(self):
        return self.frame_end - self.frame_start + 1

    def eta(self):
        """Seconds left, from the mean time per finished frame (None before the first)."""
        if not self.done or self.started is None:
            return None
        per = (time.monotonic() - self.started) / self.done
        return per * (self.total - self.done)


def write_output(folder, stream, frame, output):
    """Writes one output atomically; returns its file name. ``output`` is (kind, payload, opts)."""
    kind, payload, opts = output
    if kind == "exr":
        name = cache_mod.frame_name(stream, frame, "exr")
        exr.write(os.path.join(folder, name), payload, half=opts.get("half", ()),
                  compression=opts.get("compression", "ZIP"))
    elif kind == "vdb":
        from .. import vdb  # pyopenvdb is only needed by effects that write volumes
        name = cache_mod.frame_name(stream, frame, "vdb")
        vdb.write(os.path.join(folder, name), payload)
    elif kind == "npz":
        import numpy as np
        name = cache_mod.frame_name(stream, frame, "npz")
        with cache_mod.atomic_path(os.path.join(folder, name)) as tmp:
            with open(tmp, "wb") as f:
                np.savez_compressed(f, **payload)
    else:
        raise errors.InvalidArgument(f"output kind {kind!r}: must be exr, vdb or npz")
    return name


class BakeRunner:
    """Bakes frames [frame_start, frame_end] of ``effect`` into ``folder``.

    ``run()`` blocks; ``start()`` runs it in a thread; ``cancel()`` may be called from any
    thread and takes effect within one C progress poll."""

    def __init__(self, effect, folder, frame_start, frame_end, header=None, on_frame=None):
        if frame_end < frame_start:
            raise errors.InvalidArgument(
                f"frame_end = {frame_end}: must be >= frame_start = {frame_start}")
        if frame_start < 0:
            raise errors.InvalidArgument(f"frame_start = {frame_start}: must be >= 0")
        self.effect = effect
        self.cache = cache_mod.BakeCache(folder)
        self.state = BakeState(frame_start, frame_end)
        self.header = dict(header or {})
        self.on_frame = on_frame
        self._progress = _lib.Progress()
        self._cancel = threading.Event()
        self._thread = None
        self.error = None

    def cancel(self):
        self._cancel.set()
        self._progress.cancel = 1

    @property
    def cancelled(self):
        return self._cancel.is_set()

    def start(self):
        self._thread = threading.Thread(target=self._run_catching, name="hydrobake-bake",
                                        daemon=True)
        self._thread.start()

    def join(self, timeout=None):
        if self._thread:
            self._thread.join(timeout)
        return not (self._thread and self._thread.is_alive())

    def is_alive(self):
        return bool(self._thread and self._thread.is_alive())

    def poll_fraction(self):
        """Overall fraction including the current frame's progress inside C."""
        s = self.state
        if s.status != "RUNNING":
            return s.fraction
        inner = min(max(float(self._progress.fraction), 0.0), 1.0)
        return min((s.done + inner) / s.total, 1.0)

    def _run_catching(self):
        try:
            self.run()
        except BaseException:  # state carries the error; the thread must not die loudly
            pass

    def run(self):
        s = self.state
        s.status, s.started = "RUNNING", time.monotonic()
        try:
            header = dict(self.header, effect=self.effect.name, streams=self.effect.streams,
                          frame_start=s.frame_start, frame_end=s.frame_end,
                          params=self.effect.params_dict(), seed=self.effect.seed,
                          hydrobake=_lib.version)
            manifest = self.cache.start(header)
            for frame in range(s.frame_start, s.frame_end + 1):
                if self._cancel.is_set():
                    raise errors.Cancelled("bake cancelled")
                s.frame = frame
                self._progress.fraction = 0.0
                self.effect.step(frame, self._progress)
                if self._cancel.is_set():  # the step may have finished just as cancel came
                    raise errors.Cancelled("bake cancelled")
                files = [write_output(self.cache.folder, stream, frame, out)
                         for stream, out in self.effect.outputs(frame).items()]
                self.cache.add_frame(manifest, frame, files)
                s.done += 1
                s.fraction = s.done / s.total
                if self.on_frame:
                    self.on_frame(s)
            self.cache.finish(manifest)
            s.status = "FINISHED"
        except errors.Cancelled as exc:
            s.status, s.message, self.error = "CANCELLED", str(exc), exc
            raise
        except BaseException as exc:
            s.status, s.message, self.error = "FAILED", str(exc) or type(exc).__name__, exc
            raise
        finally:
            s.ended = time.monotonic()
