"""A bake's folder: frame-numbered files and the manifest that lists them.

Layout of a cache folder (one per .blend, object and effect):
    manifest.json          what was baked: version, effect, parameters, seed, frame range,
                           for every completed frame its files with their SHA-256, and the
                           checkpoints a resume can start from
    <stream>_0001.exr      one file per output stream and frame
    checkpoint_0010.bin    simulation state after a frame (every N frames and the latest)
Every file is written under a temporary name in the same folder and renamed when complete,
so a crash or cancel never leaves a partial file, and frames finished earlier stay valid.
"""
import contextlib
import hashlib
import json
import os
import re
import threading

MANIFEST = "manifest.json"
FORMAT_VERSION = 1
_TMP_MARK = ".tmp-"
_tmp_counter = iter(range(1 << 62))
_tmp_lock = threading.Lock()


def frame_name(stream, frame, ext):
    """``caustics_0001.exr``: Blender's image-sequence naming (frame digits last)."""
    if frame < 0:
        raise ValueError(f"frame = {frame}: must be >= 0")
    return f"{stream}_{frame:04d}.{ext}"


def temp_name(final_path):
    """A temporary name beside ``final_path``: hidden, unique per process and call."""
    folder, base = os.path.split(final_path)
    with _tmp_lock:
        n = next(_tmp_counter)
    return os.path.join(folder, f".{base}{_TMP_MARK}{os.getpid()}-{n}")


@contextlib.contextmanager
def atomic_path(final_path):
    """Yields a temporary path to write; renames it to ``final_path`` if the block succeeds,
    removes it if the block raises."""
    tmp = temp_name(final_path)
    try:
        yield tmp
        os.replace(tmp, final_path)
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            os.remove(tmp)
        raise


def write_bytes_atomic(path, data):
    with atomic_path(path) as tmp:
        with open(tmp, "wb") as f:
            f.write(data)
            f.flush()
            os.fsync(f.fileno())


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
        if m.get("format") != FORMAT_VERSION:
            raise ValueError(f"{self.manifest_path}: manifest format {m.get('format')!r}, this "
                             f"version reads {FORMAT_VERSION}")
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

    # --- free -----------------------------------------------------------------------------
    def free(self):
        """Removes the bake's files (those in the manifest, leftovers of interrupted writes of
        those streams, and the manifest), then the folder if it is empty. Nothing else."""
        if not os.path.isdir(self.folder):
            return []
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
        with contextlib.suppress(OSError):
            os.rmdir(self.folder)  # only if empty: never remove what is not ours
        return removed


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
