"""The frame loop every bake runs, in a worker thread (Blender UI) or blocking (background).

An effect (see core/effects/base.py) advances one frame per ``step`` and hands back its
outputs; the runner names, writes and records them. Cancel is honoured between frames and,
through the shared hbk_progress_t, inside long C calls.
"""
import concurrent.futures
import contextlib
import hashlib
import json
import math
import os
import threading
import time

import numpy as np

from .. import _lib, errors, exr
from . import cache as cache_mod


class BakeState:
    """What a UI needs to show; written by the runner, read by anyone."""

    def __init__(self, frame_start, frame_end):
        self.frame_start, self.frame_end = frame_start, frame_end
        self.frame = None          # frame being baked
        self.done = 0              # frames finished
        self.resumed = 0           # ... of them by the run a resume continued
        self.fraction = 0.0        # 0..1 over the whole bake
        self.status = "PENDING"    # PENDING RUNNING FINISHED CANCELLED FAILED
        self.message = ""
        self.started = None
        self.ended = None

    @property
    def total(self):
        return self.frame_end - self.frame_start + 1

    @property
    def written(self):
        """The last frame whose files are recorded (frames are recorded in order); while files
        are written beside the next step, ``frame`` is already one ahead."""
        return self.frame_start + self.done - 1

    def eta(self):
        """Seconds left, from the mean time per frame this run finished (None before the
        first; the frames a resume found done took no time now)."""
        if self.done <= self.resumed or self.started is None:
            return None
        per = (time.monotonic() - self.started) / (self.done - self.resumed)
        return per * (self.total - self.done)


def write_output(folder, stream, frame, output, tag=""):
    """Writes one output atomically; returns its file name (``tag`` before the stream).
    ``output`` is (kind, payload, opts)."""
    kind, payload, opts = output
    if kind == "exr":
        name = cache_mod.frame_name(stream, frame, "exr", tag)
        exr.write(os.path.join(folder, name), payload, half=opts.get("half", ()),
                  compression=opts.get("compression", "ZIP"))
    elif kind == "vdb":
        from .. import vdb  # pyopenvdb is only needed by effects that write volumes
        name = cache_mod.frame_name(stream, frame, "vdb", tag)
        vdb.write(os.path.join(folder, name), payload)
    elif kind == "npz":
        name = cache_mod.frame_name(stream, frame, "npz", tag)
        with cache_mod.atomic_path(os.path.join(folder, name)) as tmp:
            write_npz(tmp, payload)
    else:
        raise errors.InvalidArgument(f"output kind {kind!r}: must be exr, vdb or npz")
    return name


def write_npz(path, arrays):
    """np.savez_compressed's format, with every member dated 1980-01-01: savez stamps the
    current time into the zip, so the same arrays written a second apart differ in bytes.
    Deflate level 1: a 128^3 fluid's surface compresses in 0.3 s instead of 0.66 s at the
    default 6, to within 1% of the size."""
    import zipfile

    import numpy as np
    with zipfile.ZipFile(path, "w", compression=zipfile.ZIP_DEFLATED) as z:
        for name, arr in arrays.items():
            info = zipfile.ZipInfo(f"{name}.npy", date_time=(1980, 1, 1, 0, 0, 0))
            info.compress_type = zipfile.ZIP_DEFLATED
            for level in ("compress_level", "_compresslevel"):  # Python 3.13, 3.11
                if hasattr(info, level):
                    setattr(info, level, 1)
                    break
            with z.open(info, "w", force_zip64=True) as f:
                np.lib.format.write_array(f, np.asanyarray(arr), allow_pickle=False)


class BakeRunner:
    """Bakes frames [frame_start, frame_end] of ``effect`` into ``folder``.

    ``run()`` blocks; ``start()`` runs it in a thread; ``cancel()`` may be called from any
    thread and takes effect within one C progress poll (before ``run()``, it leaves the
    folder as it was). ``header`` goes into the manifest; its ``file_tag`` begins every
    frame file's name (a resume keeps the tag of the bake it continues)."""

    def __init__(self, effect, folder, frame_start, frame_end, header=None, on_frame=None,
                 resume=False, checkpoint_every=10):
        if frame_end < frame_start:
            raise errors.InvalidArgument(
                f"frame_end = {frame_end}: must be >= frame_start = {frame_start}")
        if frame_start < 0:
            raise errors.InvalidArgument(f"frame_start = {frame_start}: must be >= 0")
        self.effect = effect
        self.cache = cache_mod.BakeCache(folder)
        self.state = BakeState(frame_start, frame_end)
        self.header = dict(header or {})
        tag = self.header.get("file_tag", "")
        if not isinstance(tag, str) or (tag and not cache_mod.plain_name(tag)):
            raise errors.InvalidArgument(f"file_tag = {tag!r}: must be a plain file name's "
                                         "beginning (no folder, not hidden) or empty")
        self._tag = tag
        self.on_frame = on_frame
        self.resume = resume
        if checkpoint_every < 1:
            raise errors.InvalidArgument(f"checkpoint_every = {checkpoint_every}: must be >= 1")
        self.checkpoint_every = checkpoint_every
        self.resumed_from = None   # frame whose checkpoint a resume started from
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

    @property
    def started(self):
        return self._thread is not None

    def is_alive(self):
        return bool(self._thread and self._thread.is_alive())

    def poll_fraction(self):
        """Overall fraction: the frames before the one being stepped (the last of them may
        still be being written, see run) and that one's progress inside C."""
        s = self.state
        if s.status != "RUNNING":
            return s.fraction
        inner = min(max(float(self._progress.fraction), 0.0), 1.0)
        before = s.done if s.frame is None else s.frame - s.frame_start
        return min((before + inner) / s.total, 1.0)

    def _run_catching(self):
        try:
            self.run()
        except BaseException:  # state carries the error; the thread must not die loudly
            pass

    def _write_all(self, frame, outputs, checkpoint=None):
        """Writes a frame's files side by side, and runs ``checkpoint`` beside them: the C
        writers release the GIL and compress on their own threads, and a checkpoint is mostly
        waiting for the disk, so a frame's files and its checkpoint go out in parallel. Each
        file is hashed by its own thread right after it is written. Returns ({name: sha256},
        what ``checkpoint`` returned, or None without one)."""
        def write(stream, output):
            name = write_output(self.cache.folder, stream, frame, output, self._tag)
            return name, cache_mod.file_checksum(self.cache.path(name))
        items = list(outputs.items())
        if (os.cpu_count() or 1) < 2:
            files = dict(write(st, out) for st, out in items)
            return files, checkpoint() if checkpoint else None
        with concurrent.futures.ThreadPoolExecutor(len(items) + 1) as pool:
            extra = pool.submit(checkpoint) if checkpoint else None
            futures = [pool.submit(write, st, out) for st, out in items]
            files = dict(f.result() for f in futures)  # in stream order; the first error raises
            return files, extra.result() if extra else None

    def _header(self):
        s = self.state
        return dict(self.header, effect=self.effect.name, streams=list(self.effect.streams),
                    frame_start=s.frame_start, frame_end=s.frame_end,
                    params=self.effect.params_dict(), inputs=self.effect.scalar_inputs(),
                    scene=self.effect.scene_inputs(), frame_inputs={},
                    seed=self.effect.seed, hydrobake=_lib.version)

    def _resume_point(self, header):
        """(manifest, first frame to bake) continuing an earlier bake in the folder: from the
        last checkpoint up to which every frame is present and passes its checksum."""
        s = self.state
        try:
            m = self.cache.read_manifest()
        except ValueError as exc:  # (a bake error like the others: callers report those)
            raise errors.StateError(f"cannot resume: {exc}; free it or bake anew") from exc
        if m is None:
            return self.cache.start(header), s.frame_start
        for key in ("effect", "streams", "frame_start", "params", "inputs"):
            if key == "inputs" and key not in m:  # a bake from before they were recorded
                continue
            diff = _first_difference(_comparable(m.get(key)), _comparable(header[key]),
                                     "" if key in ("params", "inputs") else key)
            if diff:
                raise errors.StateError(
                    f"cannot resume the bake in {self.cache.folder}: {diff}; free it or bake "
                    "anew")
        if "scene" in m:  # (absent: a bake from before they were recorded)
            self._same_scene(m["scene"], _normal(header["scene"]), "")
        beyond = sorted(int(f) for f in m["frames"] if int(f) > s.frame_end)
        if beyond:  # a resume continues a bake; shortening one would drop good frames
            raise errors.StateError(
                f"cannot resume the bake in {self.cache.folder} to frame {s.frame_end}: it holds "
                f"frames to {beyond[-1]}; resume to its end or further, or free it to bake a "
                "shorter range")
        self.cache.remove_temporaries(m)
        bad = set(self.cache.verify())
        last = s.frame_start - 1  # last frame of the unbroken run of good frames
        while str(last + 1) in m["frames"] and last + 1 not in bad and last + 1 <= s.frame_end:
            last += 1
        if m.get("complete") and last == s.frame_end:  # nothing left to do
            self._same_frames(m, last)
            self.resumed_from = last
            return m, last + 1
        stateless = self.effect.save_state() is None
        if stateless:
            start_at = last
        else:
            good = [int(f) for f, c in m.get("checkpoints", {}).items()
                    if int(f) <= last and self.cache.check_file(c["file"], c["sha256"])]
            start_at = max(good, default=s.frame_start - 1)
        self._same_frames(m, start_at)  # (before a checkpoint's state is loaded)
        if start_at < s.frame_start:
            return self.cache.start(header), s.frame_start
        if not stateless:
            with open(self.cache.path(m["checkpoints"][str(start_at)]["file"]), "rb") as f:
                self.effect.load_state(f.read())
        m["frames"] = {f: v for f, v in m["frames"].items() if int(f) <= start_at}
        m["checkpoints"] = {f: v for f, v in m.get("checkpoints", {}).items()
                            if int(f) <= start_at}
        if "frame_inputs" in m:
            m["frame_inputs"] = {f: v for f, v in m["frame_inputs"].items()
                                 if int(f) <= start_at}
        m.update(frame_end=s.frame_end, complete=False)
        self.cache.write_manifest(m)
        self.cache.remove_unlisted_checkpoints(m)
        self.resumed_from = start_at
        return m, start_at + 1

    def _same_scene(self, there, here, where):
        """Refuses the resume where the recorded digests ``there`` of the scene's inputs (at
        frame ``where``, "" for the whole bake) differ from this run's ``here``, naming the
        first in the effect's order (the mesh before its faces' slots)."""
        for name in list(here) + sorted(set(there) - set(here)):
            if there.get(name) != here.get(name):
                how = ("new" if name not in there else "gone" if name not in here else
                       "changed")
                raise errors.StateError(
                    f"cannot resume the bake in {self.cache.folder}: {name}{where}: {how} "
                    "since the bake; free it or bake anew")

    def _same_frames(self, manifest, last):
        """Refuses the resume where what the scene's animation gave a frame up to ``last``
        (the frames the resume keeps) is not what that frame was baked from."""
        if "frame_inputs" not in manifest:  # a bake from before they were recorded
            return
        for frame in range(self.state.frame_start, last + 1):
            self._same_scene(manifest["frame_inputs"].get(str(frame), {}),
                             _normal(self.effect.frame_inputs(frame)), f" at frame {frame}")

    def _checkpoint(self, frame, state=None):
        """Writes the simulation state after ``frame`` (``state``, or the effect's now);
        returns its manifest entry (None for a stateless effect). It runs beside the frame's
        files (see _write_all): the manifest and the older checkpoints are touched only once
        everything is on disk (_keep)."""
        if state is None:
            state = self.effect.save_state()
        if state is None:
            return None
        name = cache_mod.frame_name("checkpoint", frame, "bin")
        # The checksum of the bytes being written, hashed while they are written (both let
        # the GIL go): re-reading a 200 MB fluid state to hash it cost a fifth of a second.
        with concurrent.futures.ThreadPoolExecutor(1) as pool:
            digest = pool.submit(lambda: hashlib.sha256(state).hexdigest())
            cache_mod.write_bytes_atomic(self.cache.path(name), state)
            digest = digest.result()
        return {"file": name, "sha256": digest}

    def _keep(self, manifest, frame, entry):
        """Records checkpoint ``entry`` of ``frame``: every ``checkpoint_every`` frames one is
        kept, and always the latest. Returns the files of the ones it supersedes, to remove
        once the manifest no longer names them."""
        if entry is None:
            return []
        cps = manifest.setdefault("checkpoints", {})
        gone = [cps.pop(f)["file"] for f in list(cps)
                if (int(f) - self.state.frame_start) % self.checkpoint_every and int(f) != frame]
        cps[str(frame)] = entry
        return gone

    def _due(self, frame):
        """Whether frame's checkpoint is written: every ``checkpoint_every`` frames and the
        last; in between, the latest, as long as checkpoints stay under a tenth of the bake's
        time. A checkpoint costs what writing the state costs, so small states get one every
        frame, and a 128^3 fluid (211 MB, about 0.7 s) one every few frames: a killed bake
        then re-bakes a few seconds of frames on resume, never a frame it had written. A bake
        cancelled between frames writes its latest first (run)."""
        s = self.state
        if (frame - s.frame_start) % self.checkpoint_every == 0 or frame == s.frame_end:
            return True
        return time.monotonic() - self._cp_at >= 10.0 * self._cp_cost

    def _checkpoint_timed(self, frame, state=None):
        t = time.monotonic()
        entry = self._checkpoint(frame, state)
        now = time.monotonic()
        self._cp_at, self._cp_cost = now, now - t
        return entry

    def run(self):
        """Steps each frame, then writes its files and (when due) its checkpoint. For an
        effect with ``detached_outputs`` the files of frame f are written by a second thread
        while frame f + 1 is stepped (the C step lets the GIL go): at 128^3 the fluid's files
        took as long as a third of its simulation. One frame at most is in flight; it is
        recorded in the manifest, in order, before the next is handed over, and before the
        bake stops for any reason, so a cancel or an error never drops a finished frame."""
        s = self.state
        s.status, s.started = "RUNNING", time.monotonic()
        self._cp_at, self._cp_cost = s.started, 0.0
        unsaved = None  # the last frame stepped without its checkpoint
        pending = None  # (frame, future) of the frame whose files are being written
        writer = concurrent.futures.ThreadPoolExecutor(1, thread_name_prefix="hydrobake-write")
        manifest = None
        folder = contextlib.ExitStack()  # the folder's lock, held until the writes are done

        def settle():
            """Waits for the frame in flight, records it, and counts it done."""
            nonlocal pending
            if pending is None:
                return
            frame, future = pending
            pending = None
            files, entry = future.result()
            self._commit(manifest, frame, files, entry)
            s.done += 1
            s.fraction = s.done / s.total
            if self.on_frame:
                self.on_frame(s)

        try:
            if self._cancel.is_set():  # cancelled before it began: the folder stays as it was
                raise errors.Cancelled("bake cancelled before it started")
            folder.enter_context(self.cache.locked())  # no other bake or free meanwhile
            header = self._header()
            if self.resume:
                manifest, first = self._resume_point(header)
            else:
                manifest, first = self.cache.start(header), s.frame_start
            s.done = s.resumed = first - s.frame_start
            self._tag = manifest.get("file_tag", "")  # a resume keeps the names it began with
            for frame in range(first, s.frame_end + 1):
                if self._cancel.is_set():
                    settle()
                    if unsaved is not None:  # between frames: the state is that frame's
                        self._commit(manifest, unsaved, [], self._checkpoint_timed(unsaved))
                    raise errors.Cancelled("bake cancelled")
                s.frame = frame
                self._progress.fraction = 0.0
                self.effect.step(frame, self._progress)
                if self._cancel.is_set():  # the step may have finished just as cancel came
                    raise errors.Cancelled("bake cancelled")
                due = self._due(frame)
                outputs = self.effect.outputs(frame)
                # The state of this frame, taken now: the next step changes it.
                state = self.effect.save_state() if due and self.effect.detached_outputs else None
                settle()
                checkpoint = None
                if due:
                    checkpoint = (lambda f=frame, st=state: self._checkpoint_timed(f, st))
                pending = (frame, writer.submit(self._write_all, frame, outputs, checkpoint))
                unsaved = None if due else frame
                if not self.effect.detached_outputs:
                    settle()
            settle()
            self.cache.finish(manifest)
            s.status, s.fraction = "FINISHED", 1.0
        except errors.Cancelled as exc:
            self._settle_quietly(settle)
            s.status, s.message, self.error = "CANCELLED", str(exc), exc
            raise
        except BaseException as exc:
            self._settle_quietly(settle)
            s.status, s.message, self.error = "FAILED", str(exc) or type(exc).__name__, exc
            raise
        finally:
            writer.shutdown(wait=True)
            folder.close()
            s.ended = time.monotonic()

    @staticmethod
    def _settle_quietly(settle):
        """Records the frame in flight as the bake stops; its own error, if any, must not hide
        the one that stopped the bake (it stays unrecorded and is baked again on resume)."""
        try:
            settle()
        except BaseException:
            pass

    def _commit(self, manifest, frame, files, entry):
        """Records frame's files (if any) and checkpoint (if any) in the manifest, then
        removes the checkpoints the new one supersedes."""
        gone = self._keep(manifest, frame, entry)
        if files and "frame_inputs" in manifest:  # (absent: resuming an older bake)
            made_from = _normal(self.effect.frame_inputs(frame))
            if made_from:
                manifest["frame_inputs"][str(frame)] = made_from
        if files:
            self.cache.add_frame(manifest, frame, files)
        else:
            self.cache.write_manifest(manifest)
        for name in gone:
            self.cache.remove(name)


def _normal(value):
    """JSON's view of a value (tuples become lists), for comparing with a manifest."""
    return json.loads(json.dumps(value))


def _first_difference(there, here, path=""):
    """"water.gravity: 9.81 in the bake, 5 now" for the first value (in key order) where the
    manifest's ``there`` and this run's ``here`` differ; "" where they are equal."""
    if isinstance(there, dict) and isinstance(here, dict):
        for k in sorted(set(there) | set(here)):
            sub = f"{path}.{k}" if path else str(k)
            if k not in there:
                return f"{sub}: not in the bake, {_show(here[k])} now"
            if k not in here:
                return f"{sub}: {_show(there[k])} in the bake, not set now"
            diff = _first_difference(there[k], here[k], sub)
            if diff:
                return diff
        return ""
    if there == here:
        return ""
    return f"{path or 'value'}: {_show(there)} in the bake, {_show(here)} now"


FLT_MAX = float(np.finfo(np.float32).max)


def _show(value):
    """A manifest value as the user set it: a float32 parameter (9.8100004196167 in the
    manifest) as 9.81."""
    if value is None:
        return "none"
    if isinstance(value, str):
        return value
    if isinstance(value, float) and math.isfinite(value) and abs(value) <= FLT_MAX:
        short = float(np.format_float_positional(np.float32(value), unique=True, trim="-"))
        if float(np.float32(short)) == value:  # exactly a float32: its shortest form
            return json.dumps(short)
    if isinstance(value, list):
        return "[" + ", ".join(_show(v) for v in value) + "]"
    return json.dumps(value)


def _comparable(value):
    """A manifest value without what may differ between runs of the same bake: the thread
    count (results never depend on it)."""
    value = _normal(value)
    if isinstance(value, dict):
        return {k: _comparable(v) for k, v in value.items() if k != "threads"}
    return value
