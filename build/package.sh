#!/usr/bin/env bash
# Makes the installable addon zip (with the built library): dist/hydrobake-<version>.zip.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
mkdir -p "$root/dist"
/usr/bin/python3 - "$root" <<'PY'
import os, sys, zipfile, re
root = sys.argv[1]
src = os.path.join(root, "blender_addon")
init = open(os.path.join(src, "hydrobake", "__init__.py")).read()
version = ".".join(re.search(r'"version": \((\d+), (\d+), (\d+)\)', init).groups())
out = os.path.join(root, "dist", f"hydrobake-{version}.zip")
tmp = f"{out}.{os.getpid()}.tmp"  # concurrent runs do not share it
with zipfile.ZipFile(tmp, "w", zipfile.ZIP_DEFLATED) as z:
    for d, dirs, files in os.walk(os.path.join(src, "hydrobake")):
        dirs[:] = sorted(x for x in dirs if x != "__pycache__")
        for f in sorted(files):
            if f.endswith((".pyc", ".pyo")):
                continue
            p = os.path.join(d, f)
            z.write(p, os.path.relpath(p, src))
if "hydrobake/lib/libhydrobake.so" not in zipfile.ZipFile(tmp).namelist():
    sys.exit("package: the library is missing; run build/build.sh first")
os.replace(tmp, out)
print(out)
PY
