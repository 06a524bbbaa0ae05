"""SIGKILL at the moments that matter (a frame renamed but not yet recorded, the manifest half
replaced, a checkpoint half written, a superseded checkpoint not yet removed): every frame the
manifest lists is whole, and a resume ends with the files of a bake that never stopped, and
no others."""
import os
import subprocess
import sys
import textwrap

import pytest

from hydrobake.core.bake import BakeCache, BakeRunner, cache

HERE = os.path.dirname(os.path.abspath(__file__))
ADDON = os.path.join(os.path.dirname(os.path.dirname(HERE)), "blender_addon")

EFFECT = textwrap.dedent("""
    from fixture_effect import WaveEffect

    class Stateful(WaveEffect):
        detached_outputs = DETACHED

        def save_state(self):
            return str(self.t).encode()

        def load_state(self, data):
            self.t = int(data)
    """)

# Each prelude arms one SIGKILL, then the child bakes frames 1-8.
KILLS = {
    # the superseded "latest" checkpoint, after the manifest stopped naming it: it stayed on
    # disk for good, listed nowhere (a 128^3 fluid's is 211 MB)
    "superseded-checkpoint": """
        orig = cache.BakeCache.remove
        def remove(self, name):
            if name.startswith("checkpoint_"):
                die()
            return orig(self, name)
        cache.BakeCache.remove = remove
        """,
    # frame 4's files renamed into place, the manifest not yet told
    "frame-renamed": """
        orig = runner.write_output
        def write_output(folder, stream, frame, output, tag=""):
            name = orig(folder, stream, frame, output, tag)
            if frame == 4:
                die()
            return name
        runner.write_output = write_output
        """,
    # the manifest's temporary half written (after frame 5)
    "manifest-write": """
        orig = cache.BakeCache.write_manifest
        def write_manifest(self, manifest):
            if "5" in manifest["frames"]:
                tmp = cache.temp_name(self.manifest_path)
                with open(tmp, "wb") as f:
                    f.write(b'{"format": 1, "fra')
                die()
            return orig(self, manifest)
        cache.BakeCache.write_manifest = write_manifest
        """,
    # frame 6's checkpoint half written
    "checkpoint-write": """
        orig = cache.write_bytes_atomic
        def write_bytes_atomic(path, data):
            if path.endswith("checkpoint_0006.bin"):
                with open(cache.temp_name(path), "wb") as f:
                    f.write(data[:1])
                die()
            return orig(path, data)
        cache.write_bytes_atomic = write_bytes_atomic
        """,
}


def bake_killed(folder, kill, detached):
    code = (f"import os, signal, sys\nsys.path[:0] = [{ADDON!r}, {HERE!r}]\n"
            "from hydrobake.core.bake import BakeRunner, cache, runner\n"
            "def die():\n    os.kill(os.getpid(), signal.SIGKILL)\n"
            # every frame's checkpoint written, however busy the machine (a costly one is
            # written less often): the kills below find theirs
            "runner.BakeRunner._due = lambda self, frame: True\n"
            + EFFECT.replace("DETACHED", str(detached)) + textwrap.dedent(KILLS[kill]) +
            f"BakeRunner(Stateful(delay=0.02), {str(folder)!r}, 1, 8, "
            "checkpoint_every=4).run()\n")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                       timeout=120)
    assert r.returncode == -9, (r.returncode, r.stderr)


def stateful(detached):
    namespace = {}
    exec(EFFECT.replace("DETACHED", str(detached)), namespace)
    return namespace["Stateful"]


def visible(folder):
    """The files a bake leaves (the manifest itself differs by the checkpoints it lists)."""
    return {n: (folder / n).read_bytes() for n in sorted(os.listdir(folder))
            if n != "manifest.json" and not n.startswith("checkpoint_")}


@pytest.mark.parametrize("detached", [False, True], ids=["in-order", "detached"])
@pytest.mark.parametrize("kill", sorted(KILLS))
def test_a_killed_bake_resumes_to_the_files_of_one_never_stopped(tmp_path, kill, detached):
    ref = tmp_path / "ref"
    BakeRunner(stateful(detached)(), ref, 1, 8, checkpoint_every=4).run()
    folder = tmp_path / "bake"
    bake_killed(folder, kill, detached)
    c = BakeCache(folder)
    frames = c.frames()
    assert frames == list(range(1, len(frames) + 1)) and len(frames) < 8, frames
    assert c.verify() == []  # every listed frame whole
    for entry in c.read_manifest().get("checkpoints", {}).values():
        assert c.check_file(entry["file"], entry["sha256"])
    r = BakeRunner(stateful(detached)(), folder, 1, 8, checkpoint_every=4, resume=True)
    r.run()
    assert r.state.status == "FINISHED" and c.verify() == []
    assert visible(folder) == visible(ref)
    # No temporary, no lock, and exactly the checkpoints the manifest lists.
    m = c.read_manifest()
    listed = {e["file"] for e in m["checkpoints"].values()}
    assert sorted(os.listdir(folder)) == sorted(
        ["manifest.json"] + list(visible(ref)) + list(listed))
    assert cache.LOCK not in os.listdir(folder)
