#!/usr/bin/env bash
# Builds libhydrobake.so, its tests and benchmarks, and puts the library into the addon.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
work="$root/build/_work"
mkdir -p "$work"
cmake -S "$root/c_core" -B "$work/cmake" -DCMAKE_BUILD_TYPE=Release >"$work/cmake.log" 2>&1 ||
  { cat "$work/cmake.log"; exit 1; }
if ! cmake --build "$work/cmake" -j"$(nproc)" >"$work/build.log" 2>&1; then
  grep -E "error|Error" "$work/build.log" >&2 || cat "$work/build.log" >&2
  echo "build failed: see $work/build.log" >&2
  exit 1
fi
grep -E "warning" "$work/build.log" >&2 || true
mkdir -p "$root/blender_addon/hydrobake/lib"
# Renamed into place, not copied over: a process that has the library loaded (a bake, a test)
# keeps its own copy instead of dying of SIGBUS.
lib="$root/blender_addon/hydrobake/lib/libhydrobake.so"
cp "$work/cmake/libhydrobake.so" "$lib.tmp.$$"
mv -f "$lib.tmp.$$" "$lib"
