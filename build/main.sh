#!/usr/bin/env bash
# The main job: set up, build, package, install the addon zip into a private Blender user
# folder, then bake every effect of examples.blend and render a still of each scene to out/.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
work="$root/build/_work"
"$root/build/setup.sh"
"$root/build/build.sh"
zip=$("$root/build/package.sh")
export BLENDER_USER_SCRIPTS="$work/blender_home/scripts" BLENDER_USER_CONFIG="$work/blender_home/config"
blender -b --factory-startup --python-exit-code 1 \
  --python "$root/tests/blender/scripts/install_addon.py" -- "$zip" | grep "HYDROBAKE INSTALLED"
mkdir -p "$root/out"
# Bake a copy: the committed examples.blend is never modified by a run.
cp "$root/examples.blend" "$root/out/examples.blend"
blender -b "$root/out/examples.blend" --factory-startup --python-exit-code 1 \
  --python "$root/build/run_examples.py" -- "$root/out" "$@"
ls -1 "$root"/out/*.png
