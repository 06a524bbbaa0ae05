"""A bake's folder: frame-numbered files and the manifest that lists them.

Layout of a cache folder (one per .blend, object and effect):
    manifest.json          what was baked: version, effect, parameters, seed, frame range,
                           for every completed frame its files with their SHA-256, and the
                           checkpoints a resume can start from
    <tag><stream>_0001.exr one file per output stream and frame; the tag (manifest's
                           file_tag, "" if none) makes the names unique among bakes: Blender
                           unpacks a packed image into //textures/<its file name>
    checkpoint_0010.bin    simulation state after a frame (every N frames and the latest)
    .hydrobake.lock        while a bake or free works here: locked, so that a second one in
                           another process is refused (left by a killed bake; the next one
                           takes it over and removes it)
Every file is written under a temporary name in the same folder and renamed when complete,
so a crash or cancel never leaves a partial file, and frames finished earlier stay valid.
"""
import contextlib
import errno
import hashlib
import json
import os
import re
import threading

from .. import errors

try:
    import fcntl
except ImportError:  # Windows: bakes into one folder are not guarded against each other
    fcntl = None

MANIFEST = "manifest.json"
FORMAT_VERSION = 1
LOCK = ".hydrobake.lock"  # held by the bake or free working in the folder (BakeCache.locked)
_TMP_MARK = ".tmp-"
_tmp_counter = iter(range(1 << 62))
_tmp_lock = threading.Lock()


def frame_name(stream, frame, ext, tag=""):
    """``caustics_0001.exr`` (``<tag>caustics_0001.exr`` with a tag): Blender's image-sequence
    naming (frame digits last)."""
    if frame < 0:
        raise ValueError(f"frame = {frame}: must be >= 0")
    return f"{tag}{stream}_{frame:04d}.{ext}"


def stream_stem(manifest, stream):
    """What a bake's files of ``stream`` are called before their frame numbers: the stream
    after the bake's file tag (the stream alone for a bake from before tags)."""
    return (manifest or {}).get("file_tag", "") + stream


def stem_in(folder, stream):
    """stream_stem of the bake in ``folder`` (the stream alone where none can be read)."""
    try:
        manifest = BakeCache(folder).read_manifest()
    except ValueError:
        manifest = None
    return stream_stem(manifest, stream)


def frame_path(folder, stream, frame, ext):
    """The path of the file of ``stream`` and ``frame`` of the bake in ``folder``."""
    return os.path.join(folder, frame_name(stem_in(folder, stream), frame, ext))


def untagged(manifest, name):
    """A bake's file name without its tag (``caustics_0001.exr``): what a golden bake of
    another folder, whose tag differs, calls the same file."""
    tag = (manifest or {}).get("file_tag", "")
    return name[len(tag):] if tag and name.startswith(tag) else name


def temp_name(final_path):
    """A temporary name beside ``final_path``: hidden, unique per process and call."""
    folder, base = os.path.split(final_path)
    with _tmp_lock:
        n = next(_tmp_counter)
    return os.path.join(folder, f".{base}{_TMP_MARK}{os.getpid()}-{n}")


@contextlib.contextmanager
def atomic_path(final_path):
    """Yields a temporary path to write; once the block succeeds, flushes it to the disk and
    renames it to ``final_path`` (as the C EXR writer does); removes it if anything fails.
    An OSError is raised as FileIOError naming ``final_path`` (a full disk's bare
    "[Errno 28] No space left on device" did not say which file)."""
    tmp = temp_name(final_path)
    try:
        yield tmp
        _sync(tmp)
        os.replace(tmp, final_path)
        _sync_folder(os.path.dirname(os.path.abspath(final_path)))
    except BaseException as exc:
        with contextlib.suppress(OSError):  # the folder may be gone: keep the first error
            os.remove(tmp)
        if isinstance(exc, OSError) and not isinstance(exc, errors.HydrobakeError):
            raise errors.FileIOError(f'"{final_path}": cannot write it: '
                                     f"{exc.strerror or exc}") from exc
        raise


def _sync(path):
    fd = os.open(path, os.O_RDONLY | getattr(os, "O_CLOEXEC", 0))
    try:
        os.fsync(fd)
    except OSError as exc:
        if exc.errno not in (errno.EINVAL, errno.EROFS):  # a file system without fsync
            raise
    finally:
        os.close(fd)


def _sync_folder(folder):
    """The rename made to last past a power cut, as far as the system allows (best effort:
    the file is complete either way, and a resume's checksums find a lost rename)."""
    with contextlib.suppress(OSError):
        fd = os.open(folder, os.O_RDONLY | getattr(os, "O_DIRECTORY", 0))
        try:
            os.fsync(fd)
        finally:
            os.close(fd)


def write_bytes_atomic(path, data):
    with atomic_path(path) as tmp:  # which flushes it to the disk
        with open(tmp, "wb") as f:
            f.write(data)


def file_checksum(path):
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


class BakeCache:
    """One cache folder. The manifest is rewritten (atomically) after every frame."""

    def __init__(self, folder):
        self.folder = os.path.abspath(folder)
        self.manifest_path = os.path.join(self.folder, MANIFEST)
        self._lock = None  # the lock file's descriptor while this holds the folder

    # --- manifest -------------------------------------------------------------------------
    def read_manifest(self):
        """The manifest dict, or None if there is no bake here."""
        try:
            with open(self.manifest_path, "rb") as f:
                m = json.loads(f.read())
        except (FileNotFoundError, NotADirectoryError):  # no folder can be there either
            return None
        except (OSError, ValueError) as exc:
            raise ValueError(f"{self.manifest_path}: unreadable manifest ({exc})") from exc
        if not isinstance(m, dict) or m.get("format") != FORMAT_VERSION:
            found = m.get("format") if isinstance(m, dict) else type(m).__name__
            raise ValueError(f"{self.manifest_path}: manifest format {found!r}, this "
                             f"version reads {FORMAT_VERSION}")
        problem = _manifest_problem(m)
        if problem:  # edited by hand, or not ours: never act on it (free removes what it names)
            raise ValueError(f"{self.manifest_path}: unreadable manifest ({problem})")
        return m

    def write_manifest(self, manifest):
        manifest = dict(manifest, format=FORMAT_VERSION)
        data = json.dumps(manifest, indent=1, sort_keys=True).encode()
        write_bytes_atomic(self.manifest_path, data)

    def start(self, header):
        """Begins a fresh bake: the header (version, effect, params, seed, frame range, ...)
        and an empty frame list. Files of an earlier bake here are removed first."""
        self.free()
        os.makedirs(self.folder, exist_ok=True)
        manifest = dict(header, frames={}, complete=False)
        self.write_manifest(manifest)
        return manifest

    def add_frame(self, manifest, frame, files):
        """Records a completed frame: ``files`` are names in the folder, already renamed, or
        a dict of names to their sha256 when the writer has hashed them already."""
        if not isinstance(files, dict):
            files = {name: file_checksum(os.path.join(self.folder, name)) for name in files}
        manifest["frames"][str(frame)] = dict(files)
        self.write_manifest(manifest)

    def finish(self, manifest):
        manifest["complete"] = True
        self.write_manifest(manifest)

    # --- queries --------------------------------------------------------------------------
    def frames(self):
        """Sorted frame numbers recorded as complete."""
        m = self.read_manifest()
        return sorted(int(f) for f in m["frames"]) if m else []

    def verify(self):
        """Frames whose files are missing or fail their checksum."""
        m = self.read_manifest()
        bad = []
        for frame, files in (m or {}).get("frames", {}).items():
            for name, digest in files.items():
                p = os.path.join(self.folder, name)
                if not os.path.isfile(p) or file_checksum(p) != digest:
                    bad.append(int(frame))
                    break
        return sorted(bad)

    def path(self, name):
        return os.path.join(self.folder, name)

    def check_file(self, name, digest):
        p = self.path(name)
        return os.path.isfile(p) and file_checksum(p) == digest

    def remove(self, name):
        with contextlib.suppress(FileNotFoundError):
            os.remove(self.path(name))

    def _temporaries(self, manifest):
        """Leftovers of interrupted writes here: ".<final name>.tmp-<pid>-<n>", ours when the
        final name is the manifest's or one of its streams'."""
        names, streams = _names(manifest), _streams(manifest)
        out = []
        for entry in os.listdir(self.folder):
            mt = re.match(r"^\.(.+)" + re.escape(_TMP_MARK) + r"\d+-\d+$", entry)
            if mt and (mt.group(1) in names or mt.group(1) == MANIFEST or
                       _stream_of(mt.group(1)) in streams):
                out.append(entry)
        return out

    def remove_temporaries(self, manifest):
        """Removes what a killed bake was writing (a bake resumed here writes them anew)."""
        for name in self._temporaries(manifest):
            self.remove(name)

    def remove_unlisted_checkpoints(self, manifest):
        """Removes the checkpoints ``manifest`` does not list: those of frames a resume bakes
        again, and one a killed bake had superseded but not yet removed (else each was left
        for good: up to a 211 MB state per kill)."""
        listed = {c["file"] for c in manifest.get("checkpoints", {}).values()}
        for name in os.listdir(self.folder):
            if _stream_of(name) == "checkpoint" and name not in listed:
                self.remove(name)

    # --- lock -----------------------------------------------------------------------------
    @contextlib.contextmanager
    def locked(self):
        """Holds the folder for one bake or free: an exclusive lock on its LOCK file (made
        here, with the folder if need be). Another process's bake or free here meanwhile is
        refused with FileIOError instead of deleting this one's files (a second bake began
        with free, and removed the first's frames and the temporaries it was writing). The
        system lets go of the lock when a process dies, so a killed bake never blocks the
        next; the file itself goes when the lock is let go. Re-entrant; a file system
        without locks is used without."""
        if self._lock is not None or fcntl is None:
            yield
            return
        if os.path.exists(self.folder) and not os.path.isdir(self.folder):
            raise errors.FileIOError(f"{self.folder}: is a file, not a folder: the bake's "
                                     "folder cannot be made there")
        path = os.path.join(self.folder, LOCK)
        for _attempt in range(100):
            os.makedirs(self.folder, exist_ok=True)
            try:
                fd = os.open(path, os.O_RDWR | os.O_CREAT | getattr(os, "O_CLOEXEC", 0), 0o644)
            except FileNotFoundError:  # a free removed the folder just now
                continue
            except OSError as exc:
                raise errors.FileIOError(f"{self.folder}: cannot write in it: "
                                         f"{exc.strerror or exc}") from exc
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except OSError as exc:
                os.close(fd)
                if exc.errno in (errno.EWOULDBLOCK, errno.EAGAIN, errno.EACCES):
                    raise errors.FileIOError(
                        f"{self.folder}: another bake or free is working in this folder (a "
                        "second Blender or batch process); wait for it to end or cancel it"
                    ) from None
                fd = None  # no locks on this file system
                break
            with contextlib.suppress(OSError):
                if os.fstat(fd).st_ino == os.stat(path).st_ino:
                    break  # else its holder removed it as it let go: lock the new one
            os.close(fd)
        else:
            raise errors.FileIOError(f"{self.folder}: cannot lock the folder")
        self._lock = fd
        try:
            yield
        finally:
            self._lock = None
            if fd is not None:
                with contextlib.suppress(OSError):
                    os.remove(path)  # before the lock goes: the next one makes a new file
                os.close(fd)

    # --- free -----------------------------------------------------------------------------
    def free(self):
        """Removes the bake's files (those in the manifest, leftovers of interrupted writes of
        those streams, and the manifest), then the folder if it is empty. Nothing else."""
        if not os.path.isdir(self.folder):
            return []
        outer = self._lock is None
        with self.locked():
            removed = self._free()
        if outer:
            with contextlib.suppress(OSError):
                os.rmdir(self.folder)  # only if empty: never remove what is not ours
        return removed

    def _free(self):
        removed = []
        try:
            m = self.read_manifest()
        except ValueError:
            m = None
        names = _names(m)
        streams = _streams(m)
        names.update(self._temporaries(m))
        names.update(e for e in os.listdir(self.folder) if _stream_of(e) in streams)
        for name in sorted(names):
            with contextlib.suppress(FileNotFoundError):
                os.remove(os.path.join(self.folder, name))
                removed.append(name)
        if m is not None:
            os.remove(self.manifest_path)
            removed.append(MANIFEST)
        return removed


def plain_name(name):
    """A file name in the folder itself: not a path, not hidden (temporaries are)."""
    return (isinstance(name, str) and name not in ("", ".", "..") and not name.startswith(".")
            and "/" not in name and os.sep not in name and (os.altsep or "/") not in name)


def _number(key):
    return re.fullmatch(r"[0-9]+", key) is not None


def _manifest_problem(m):
    """What is wrong with the shape of manifest ``m`` ("" if nothing): the frame lists and
    checkpoints the bake and free act on."""
    streams = m.get("streams", [])
    if not isinstance(streams, list) or not all(isinstance(x, str) for x in streams):
        return "streams: not a list of names"
    tag = m.get("file_tag", "")
    if not isinstance(tag, str) or (tag and not plain_name(tag)):
        return "file_tag: not a file name's beginning"
    frames = m.get("frames")
    if not isinstance(frames, dict):
        return "no frame list"
    for frame, files in frames.items():
        if not _number(frame):
            return f"frame {frame!r} is not a frame number"
        if not isinstance(files, dict):
            return f"frame {frame}: not a list of files"
        for name, digest in files.items():
            if not plain_name(name) or not isinstance(digest, str) or \
                    ("streams" in m and _stream_of(untagged(m, name)) not in streams):
                return f"frame {frame}: file {name!r} is not a file of the bake"
    checkpoints = m.get("checkpoints", {})
    if not isinstance(checkpoints, dict):
        return "checkpoints: not a list of checkpoints"
    for frame, entry in checkpoints.items():
        if not _number(frame) or not isinstance(entry, dict) or \
                not plain_name(entry.get("file")) or \
                _stream_of(entry["file"]) != "checkpoint" or \
                not isinstance(entry.get("sha256"), str):
            return f"checkpoint {frame!r}: not a checkpoint of the bake"
    scene = m.get("scene", {})
    if not _digests(scene):
        return "scene: not a list of digests"
    made_from = m.get("frame_inputs", {})
    if not isinstance(made_from, dict) or not all(
            _number(f) and _digests(d) for f, d in made_from.items()):
        return "frame_inputs: not a list of digests per frame"
    return ""


def _digests(d):
    """Whether ``d`` is a manifest's {name: digest} (what the scene gave the bake)."""
    return isinstance(d, dict) and all(isinstance(v, str) for v in d.values())


def _names(manifest):
    """The files a manifest lists: its frames' and its checkpoints'."""
    names = set()
    for files in (manifest or {}).get("frames", {}).values():
        names.update(files)
    names.update(c["file"] for c in (manifest or {}).get("checkpoints", {}).values())
    return names


def _streams(manifest):
    return set((manifest or {}).get("streams", [])) | {"checkpoint"}


def _stream_of(name):
    m = re.match(r"^(.+)_\d{4,}\.[A-Za-z0-9]+$", name)
    return m.group(1) if m else None
