"""Blender's own shared-folder farm (placeholders, no overwrite): several processes render one
baked file into one folder, share the frames between them, and every frame reads the finished
bake. (Blender checks for a placeholder and then writes it, so two machines starting the same
frame at the same instant can both render it; that race is Blender's, and harmless.)"""
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
    saved = [[line for line in o.splitlines() if line.startswith("Saved:")] for o in outs]
    files = sorted(os.listdir(tmp_path / "frames"))
    assert files == [f"f_{i:04d}.png" for i in range(1, 7)]
    # The placeholders share the work: a frame one machine has taken is skipped by the other,
    # so the renders add up to the frames, but for the race above (at most one per machine).
    # How they split depends on start-up times: on a busy machine the second Blender may
    # start when the first has taken every frame, and then renders none.
    rendered = [os.path.basename(line.split("'")[1]) for o in saved for line in o]
    assert sorted(set(rendered)) == files
    assert len(rendered) <= len(files) + 2, saved
    from PIL import Image
    for f in files:  # every frame is a finished render that found the baked caustic maps
        img = Image.open(tmp_path / "frames" / f).convert("RGB")
        assert img.size == (48, 27)
        assert not any(r > 230 and g < 25 and b > 230 for r, g, b in img.getdata())
