"""Helpers the Blender tests share (imported by plain pytest, not inside Blender)."""
import glob
import json
import os
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, os.path.join(ROOT, "blender_addon"))


def frames_in(folder):
    """Frames the manifest of ``folder`` records as complete ([] if none yet)."""
    try:
        with open(os.path.join(folder, "manifest.json")) as f:
            return sorted(int(k) for k in json.load(f)["frames"])
    except (FileNotFoundError, ValueError):
        return []


def override_cases(blender, blend, target, cases, tmp_path):
    """Runs --overrides tables [(table, want)] on ``target`` ({"objects": [...], "effects":
    [...]}) in one Blender run (cli_overrides.py) and checks each: want None, accepted; else
    refused with an error containing want. Returns the "CASE ..." lines."""
    spec = tmp_path / "cases.json"
    spec.write_text(json.dumps([dict(target, table=t) for t, _ in cases]))
    r = blender.run("cli_overrides.py", spec, blend=blend)
    lines = [line for line in r.stdout.splitlines() if line.startswith("CASE ")]
    assert len(lines) == len(cases), r.stdout[-3000:]
    for i, (line, (table, want)) in enumerate(zip(lines, cases)):
        if want is None:
            assert line == f"CASE {i} OK", (table, line)
        else:
            assert line.startswith(f"CASE {i} ERROR ") and want in line, (table, line, want)
    return lines


def addon_zip():
    zips = sorted(glob.glob(os.path.join(ROOT, "dist", "hydrobake-*.zip")))
    if not zips:
        raise FileNotFoundError("dist/hydrobake-*.zip is missing: run build/package.sh")
    return zips[-1]
