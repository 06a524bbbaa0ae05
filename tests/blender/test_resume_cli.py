"""A killed caustics bake, resumed from the command line, equals an uninterrupted one."""
import os
import shutil
import signal
import time

from hydrobake_paths import ROOT, frames_in

ARGS = ("--objects", "Water", "--effects", "caustics", "--frames", "1-10", "--threads", "2")


def exr_bytes(folder):
    return {n: open(os.path.join(folder, n), "rb").read() for n in sorted(os.listdir(folder))
            if n.endswith(".exr")}


def test_kill_then_resume_is_bit_identical(blender, tmp_path):
    blend = str(tmp_path / "pool.blend")
    shutil.copy(os.path.join(ROOT, "examples.blend"), blend)
    ref, cut = tmp_path / "ref", tmp_path / "cut"
    blender.run("cli.py", "bake", *ARGS, "--output", ref, blend=blend)
    folder = cut / "pool" / "Water_caustics"
    p = blender.popen("cli.py", "bake", *ARGS, "--output", cut, "--threads", "1", blend=blend)
    deadline = time.monotonic() + 120
    while len(frames_in(folder)) < 3 and time.monotonic() < deadline and p.poll() is None:
        time.sleep(0.02)
    p.send_signal(signal.SIGKILL)
    p.wait(10)
    killed_at = frames_in(folder)
    assert 3 <= len(killed_at) < 10, killed_at
    r = blender.run("cli.py", "resume", *ARGS, "--output", cut, blend=blend)
    assert "resumed after frame" in r.stdout
    ref_files = exr_bytes(ref / "pool" / "Water_caustics")
    assert len(ref_files) == 40 and exr_bytes(folder) == ref_files
    assert not [n for n in os.listdir(folder) if n.startswith(".")]  # no temporaries left
