#!/usr/bin/env bash
# Builds libhydrobake.so, its tests and benchmarks, and puts the library into the addon.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
work="$root/build/_work"
cmake -S "$root/c_core" -B "$work/cmake" -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build "$work/cmake" -j"$(nproc)" 2>&1 | grep -E "warning|error|Error" || true
test -f "$work/cmake/libhydrobake.so"
mkdir -p "$root/blender_addon/hydrobake/lib"
cp "$work/cmake/libhydrobake.so" "$root/blender_addon/hydrobake/lib/libhydrobake.so"
