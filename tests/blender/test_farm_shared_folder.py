"""Blender's own shared-folder farm (placeholders, no overwrite): several processes render one
baked file into one folder; every frame is rendered exactly once and reads the finished bake."""
import os
import shutil
import subprocess

from hydrobake_paths import ROOT


def test_two_machines_render_each_frame_once(blender, tmp_path):
    blend = tmp_path / "farm.blend"
    shutil.copy(os.path.join(ROOT, "examples.blend"), blend)
    frames = tmp_path / "frames" / "f_####"
    blender.run("farm_prepare.py", frames, blend=str(blend))
    procs = [subprocess.Popen([shutil.which("blender") or "/usr/bin/blender",
                               "-b", str(blend), "--python-exit-code", "1", "-a"],
                              env=blender.env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                              text=True) for _ in range(2)]
    outs = [p.communicate(timeout=600)[0] for p in procs]
    assert all(p.returncode == 0 for p in procs), outs
    saved = [line for o in outs for line in o.splitlines() if line.startswith("Saved:")]
    files = sorted(os.listdir(tmp_path / "frames"))
    assert files == [f"f_{i:04d}.png" for i in range(1, 7)]
    assert len(saved) == 6, saved  # no frame rendered twice
    assert all(os.path.getsize(tmp_path / "frames" / f) > 0 for f in files)  # no placeholder left
