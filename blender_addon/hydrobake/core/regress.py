"""Regression of baked outputs against a golden bake. Never imports bpy.

    python3 -m hydrobake.core.regress NEW GOLDEN [--tolerances T.json] [--report DIR]

NEW and GOLDEN are bake folders (with manifest.json) or folders of them (compared by relative
path). Per file and channel or grid: maximum and mean absolute difference and PSNR for images,
active voxels and value differences for VDB grids, counts and distances for point sets.
Tolerances come per effect and stream from a small JSON file (see DEFAULT_TOLERANCES). Writes a
text summary to stdout, ``report.json`` and ``report.html`` (golden, new and difference images
side by side) to the report folder; the exit code is 1 on any regression.
"""
import argparse
import html
import json
import math
import os
import sys
import zipfile

import numpy as np

from . import errors, jsonfile
from .bake.cache import MANIFEST, BakeCache, untagged, write_bytes_atomic

# Per stream: max_abs (largest allowed |new - golden|), mean_abs, min_psnr (dB), and for VDB
# max_voxel_delta (active voxel count change) — any missing key is not checked. "*" applies
# to streams not named. Images of the same bake on the same build match bit for bit; these
# leave room for another compiler or CPU.
DEFAULT_TOLERANCES = {
    "*": {"*": {"max_abs": 1e-4, "mean_abs": 1e-5, "min_psnr": 80.0, "max_voxel_delta": 0}},
    "caustics": {"caustics": {"max_abs": 2e-2, "mean_abs": 1e-3, "min_psnr": 50.0},
                 "*": {"max_abs": 1e-4, "mean_abs": 1e-5, "min_psnr": 80.0}},
    "snow": {"coverage": {"max_abs": 0.05, "mean_abs": 1e-3, "min_psnr": 45.0},
             "depth": {"max_abs": 1e-4, "mean_abs": 1e-6, "min_psnr": 60.0}},
}


TOLERANCE_KEYS = ("max_abs", "mean_abs", "min_psnr", "max_voxel_delta")


def check_tolerances(table, where="tolerances"):
    """Refuses, naming the place, what would check less than it seems to: a misspelt key
    (nothing would be checked), a value that is not a finite number >= 0 (NaN passes every
    comparison), or a table of another shape."""
    shape = "{effect or '*': {stream or '*': {tolerance: number}}}"
    if not isinstance(table, dict):
        raise ValueError(f"{where}: must be a JSON object {shape}")
    for effect, streams in table.items():
        if not isinstance(streams, dict):
            raise ValueError(f"{where}: {effect}: must be an object of streams, {shape}")
        for stream, tol in streams.items():
            at = f"{where}: {effect}/{stream}"
            if not isinstance(tol, dict):
                raise ValueError(f"{at}: must be an object of tolerances "
                                 f"({', '.join(TOLERANCE_KEYS)})")
            for key, value in tol.items():
                if key not in TOLERANCE_KEYS:
                    raise ValueError(f"{at}: {key!r} is not a tolerance (tolerances: "
                                     f"{', '.join(TOLERANCE_KEYS)})")
                if isinstance(value, bool) or not isinstance(value, (int, float)) or \
                        not math.isfinite(value) or value < 0:
                    raise ValueError(f"{at}: {key} = {json.dumps(value)}: must be a finite "
                                     "number >= 0")
    return table


def tolerance(tolerances, effect, stream):
    by_effect = tolerances.get(effect, tolerances.get("*", {}))
    t = dict(tolerances.get("*", {}).get("*", {}))
    t.update(by_effect.get("*", {}))
    t.update(by_effect.get(stream, {}))
    return t


def image_metrics(new, golden):
    d = np.abs(new.astype(np.float64) - golden.astype(np.float64))
    finite = np.isfinite(d)
    if not finite.all():
        return {"max_abs": math.inf, "mean_abs": math.inf, "psnr": 0.0, "nonfinite": int(
            (~finite).sum())}
    mse = float((d * d).mean())
    peak = float(max(np.abs(golden).max(), 1e-12))
    psnr = math.inf if mse == 0 else 10.0 * math.log10(peak * peak / mse)
    return {"max_abs": float(d.max()), "mean_abs": float(d.mean()), "psnr": psnr}


def _check(metrics, tol):
    bad = []
    if "max_abs" in tol and metrics.get("max_abs", 0) > tol["max_abs"]:
        bad.append(f"max |diff| {metrics['max_abs']:.3g} > {tol['max_abs']:.3g}")
    if "mean_abs" in tol and metrics.get("mean_abs", 0) > tol["mean_abs"]:
        bad.append(f"mean |diff| {metrics['mean_abs']:.3g} > {tol['mean_abs']:.3g}")
    if "min_psnr" in tol and "psnr" in metrics and metrics["psnr"] < tol["min_psnr"]:
        bad.append(f"PSNR {metrics['psnr']:.1f} dB < {tol['min_psnr']:.1f}")
    if "max_voxel_delta" in tol and abs(metrics.get("voxel_delta", 0)) > tol["max_voxel_delta"]:
        bad.append(f"active voxels changed by {metrics['voxel_delta']}")
    return bad


def compare_exr(new_path, golden_path):
    from . import exr
    a, b = exr.read(new_path), exr.read(golden_path)
    out = {}
    for ch in sorted(set(a) | set(b)):
        if ch not in a or ch not in b:
            out[ch] = {"error": f"channel {ch} only in {'golden' if ch in b else 'new'}"}
        elif a[ch].shape != b[ch].shape:
            out[ch] = {"error": f"size {a[ch].shape} != golden {b[ch].shape}"}
        else:
            out[ch] = image_metrics(a[ch], b[ch])
    return out


def compare_vdb(new_path, golden_path):
    from . import vdb
    a, b = vdb.read(new_path), vdb.read(golden_path)
    out = {}
    for name in sorted(set(a) | set(b)):
        if name not in a or name not in b:
            out[name] = {"error": f"grid {name} only in {'golden' if name in b else 'new'}"}
            continue
        ga, gb = a[name], b[name]
        boxes = [g.evalActiveVoxelBoundingBox() for g in (ga, gb) if g.activeVoxelCount()]
        vec = ga.valueTypeName.startswith("vec3")
        if not boxes:  # both empty
            out[name] = {"max_abs": 0.0, "mean_abs": 0.0, "voxels": 0, "voxel_delta": 0}
            continue
        lo = [min(bx[0][i] for bx in boxes) for i in range(3)]
        hi = [max(bx[1][i] for bx in boxes) for i in range(3)]
        shape = tuple(h - l + 1 for l, h in zip(lo, hi))
        arrs = []
        for g in (ga, gb):
            arr = np.zeros(shape + ((3,) if vec else ()), np.float32)
            if g.activeVoxelCount():
                g.copyToArray(arr, ijk=tuple(lo))
            arrs.append(arr)
        m = image_metrics(arrs[0], arrs[1])
        m["voxels"] = int(ga.activeVoxelCount())
        m["voxel_delta"] = int(ga.activeVoxelCount()) - int(gb.activeVoxelCount())
        out[name] = m
    return out


def compare_npz(new_path, golden_path):
    a, b = np.load(new_path), np.load(golden_path)
    out = {}
    for name in sorted(set(a.files) | set(b.files)):
        if name not in a.files or name not in b.files:
            out[name] = {"error": f"array {name} only in {'golden' if name in b.files else 'new'}"}
            continue
        x, y = a[name], b[name]
        m = {"count": int(len(x)), "count_delta": int(len(x) - len(y))}
        if x.shape == y.shape:
            d = np.abs(x.astype(np.float64) - y)
            dist = np.linalg.norm(d, axis=-1) if d.ndim > 1 else d
            m.update(max_abs=float(d.max(initial=0)), mean_abs=float(d.mean()) if d.size else 0.0,
                     max_distance=float(dist.max(initial=0)))
        else:
            m["error"] = f"shape {x.shape} != golden {y.shape}"
        out[name] = m
    return out


COMPARERS = {".exr": compare_exr, ".vdb": compare_vdb, ".npz": compare_npz}


def bake_folders(root):
    """Relative paths of bake folders (holding a manifest) under root (root itself too)."""
    out = []
    for d, dirs, files in os.walk(root):
        dirs.sort()
        if MANIFEST in files:
            out.append(os.path.relpath(d, root))
    return out


def compare(new_root, golden_root, tolerances=None, only=None):
    """The report: a dict with one entry per file and the overall verdict. only: the bake
    folders (relative to the roots, '<object>_<effect>') to compare; None = every golden one."""
    tolerances = check_tolerances(tolerances or DEFAULT_TOLERANCES)
    report = {"new": os.path.abspath(new_root), "golden": os.path.abspath(golden_root),
              "files": [], "problems": []}
    golden_bakes = bake_folders(golden_root)
    if only is not None:
        golden_bakes = [rel for rel in golden_bakes if rel in set(only)]
    if not golden_bakes:
        report["problems"].append(f"no bake (manifest.json) under golden {golden_root}")
    for rel in golden_bakes:
        g = BakeCache(os.path.join(golden_root, rel)).read_manifest()
        n_cache = BakeCache(os.path.join(new_root, rel))
        n = n_cache.read_manifest()
        if n is None:
            report["problems"].append(f"{rel}: no bake in the new folder")
            continue
        for frame in sorted(g["frames"], key=int):
            # Files are matched by name without their bake's file tag: the tag names the
            # folder a bake was made in, which a golden copied elsewhere keeps.
            new_names = {untagged(n, x): x for x in n["frames"].get(frame, {})}
            for golden_name in sorted(g["frames"][frame], key=lambda x: untagged(g, x)):
                name = untagged(g, golden_name)
                entry = {"bake": rel, "effect": g["effect"], "frame": int(frame), "file": name,
                         "stream": name.rsplit("_", 1)[0], "channels": {}, "problems": []}
                new_path = n_cache.path(new_names.get(name, name))
                entry["paths"] = {"new": new_path,
                                  "golden": os.path.join(golden_root, rel, golden_name)}
                if name not in new_names or not os.path.isfile(new_path):
                    entry["problems"].append("missing in the new bake")
                else:
                    ext = os.path.splitext(name)[1]
                    if ext not in COMPARERS:
                        entry["problems"].append(f"no comparison for {ext or 'extensionless'} "
                                                 "files")
                        report["files"].append(entry)
                        continue
                    try:
                        entry["channels"] = COMPARERS[ext](new_path,
                                                           entry["paths"]["golden"])
                    except (errors.HydrobakeError, OSError, ValueError, EOFError,
                            zipfile.BadZipFile) as exc:  # a damaged file, new or golden
                        entry["problems"].append(f"unreadable: {exc}")
                        report["files"].append(entry)
                        continue
                    tol = tolerance(tolerances, g["effect"], entry["stream"])
                    entry["tolerance"] = tol
                    if not tol:  # a table naming other effects only: nothing would be checked
                        entry["problems"].append(
                            f"no tolerance for {g['effect']}/{entry['stream']}: name it, "
                            f"{g['effect']}/*, or */* in the tolerances")
                    for ch, m in entry["channels"].items():
                        if "error" in m:
                            entry["problems"].append(f"{ch}: {m['error']}")
                        else:
                            entry["problems"] += [f"{ch}: {p}" for p in _check(m, tol)]
                report["files"].append(entry)
    report["regressions"] = sum(bool(e["problems"]) for e in report["files"]) + len(
        report["problems"])
    report["passed"] = report["regressions"] == 0
    return report


def summary(report):
    lines = []
    for e in report["files"]:
        worst = max((m.get("max_abs", 0) for m in e["channels"].values()), default=0)
        status = "FAIL" if e["problems"] else "ok  "
        lines.append(f"{status} {e['bake']}/{e['file']}  max|diff| {worst:.3g}" +
                     (f"  ({'; '.join(e['problems'])})" if e["problems"] else ""))
    lines += [f"FAIL {p}" for p in report["problems"]]
    lines.append(f"{len(report['files']) - sum(bool(e['problems']) for e in report['files'])} "
                 f"files match, {report['regressions']} regressions")
    return "\n".join(lines)


def _preview(arr, path):
    """A PNG of a float image (tone-mapped to 8 bits), via Pillow; False without it."""
    try:
        from PIL import Image
    except ImportError:
        return False
    a = np.nan_to_num(arr.astype(np.float64))
    hi = max(float(np.percentile(np.abs(a), 99.5)), 1e-12)
    img = (np.clip(np.abs(a) / hi, 0, 1) ** (1 / 2.2) * 255).astype(np.uint8)[::-1]  # row 0 up
    tmp = path + ".tmp.png"
    Image.fromarray(img).save(tmp)
    os.replace(tmp, path)
    return True


def write_report(report, folder, max_images=24):
    """report.json and report.html (golden | new | |difference| per channel of the worst
    files) in ``folder``."""
    from . import exr
    os.makedirs(folder, exist_ok=True)
    write_bytes_atomic(os.path.join(folder, "report.json"),
                       json.dumps(report, indent=1, default=float).encode())
    rows, shown = [], 0
    ranked = sorted(report["files"], key=lambda e: (not e["problems"], -max(
        (m.get("max_abs", 0) for m in e["channels"].values()), default=0)))
    for e in ranked:
        cells = ""
        if e["file"].endswith(".exr") and e["channels"] and shown < max_images:
            new, gold = exr.read(e["paths"]["new"]), exr.read(e["paths"]["golden"])
            ch = max((c for c in e["channels"] if "max_abs" in e["channels"][c]),
                     key=lambda c: e["channels"][c]["max_abs"], default=None)
            if ch is not None:
                base = f"{e['bake'].replace(os.sep, '_')}_{e['file']}_{ch}".replace(".", "_")
                imgs = {"golden": gold[ch], "new": new[ch], "diff": new[ch] - gold[ch]}
                ok = all(_preview(a, os.path.join(folder, f"{base}_{k}.png"))
                         for k, a in imgs.items())
                if ok:
                    cells = "".join(f'<td><img src="{html.escape(base)}_{k}.png" width="256">'
                                    f"<br>{k} ({html.escape(ch)})</td>" for k in imgs)
                    shown += 1
        status = "FAIL" if e["problems"] else "ok"
        metrics = "<br>".join(
            f"{html.escape(c)}: max {m.get('max_abs', 0):.3g}, mean {m.get('mean_abs', 0):.3g}"
            + (f", PSNR {m['psnr']:.1f} dB" if "psnr" in m else "")
            for c, m in e["channels"].items() if "error" not in m)
        rows.append(f"<tr class='{status}'><td>{status}</td><td>{html.escape(e['bake'])}/"
                    f"{html.escape(e['file'])}<br>{html.escape('; '.join(e['problems']))}</td>"
                    f"<td>{metrics}</td>{cells}</tr>")
    page = f"""<!doctype html><meta charset="utf-8"><title>Hydrobake regression</title>
<style>body{{font:14px sans-serif}} .FAIL td{{background:#fdd}} td{{vertical-align:top;
padding:4px}} img{{image-rendering:pixelated}}</style>
<h1>Hydrobake regression: {'PASSED' if report['passed'] else 'FAILED'}</h1>
<p>new: {html.escape(report['new'])}<br>golden: {html.escape(report['golden'])}<br>
{report['regressions']} regressions in {len(report['files'])} files.
{''.join(f'<br>FAIL {html.escape(p)}' for p in report['problems'])}</p>
<table>{''.join(rows)}</table>"""
    write_bytes_atomic(os.path.join(folder, "report.html"), page.encode())


def load_tolerances(path):
    """The tolerances in the JSON file ``path`` (the built-in ones for none), checked; a
    ValueError names the file."""
    if not path:
        return DEFAULT_TOLERANCES
    return check_tolerances(jsonfile.read(path, "--tolerances"), f"--tolerances {path}")


def main(argv=None):
    ap = argparse.ArgumentParser(prog="hydrobake-regress", description=__doc__.split("\n")[0])
    ap.add_argument("new")
    ap.add_argument("golden")
    ap.add_argument("--tolerances", help="JSON file of tolerances per effect and stream")
    ap.add_argument("--report", help="folder for report.json and report.html")
    args = ap.parse_args(argv)
    try:
        tolerances = load_tolerances(args.tolerances)
    except ValueError as exc:
        ap.error(str(exc))
    report = compare(args.new, args.golden, tolerances)
    print(summary(report))
    if args.report:
        write_report(report, args.report)
        print(f"report: {os.path.join(args.report, 'report.html')}")
    return 0 if report["passed"] else 1


if __name__ == "__main__":
    sys.exit(main())
