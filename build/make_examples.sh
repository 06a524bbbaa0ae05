#!/usr/bin/env bash
# Regenerates examples.blend from build/make_examples.py with the freshly built addon.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
"$root/build/build.sh"
zip=$("$root/build/package.sh")
export BLENDER_USER_SCRIPTS="$root/build/_work/blender_home/scripts"
export BLENDER_USER_CONFIG="$root/build/_work/blender_home/config"
blender -b --factory-startup --python-exit-code 1 \
  --python "$root/tests/blender/scripts/install_addon.py" -- "$zip" | grep -q "HYDROBAKE INSTALLED"
blender -b --factory-startup --python-exit-code 1 --python "$root/build/make_examples.py" \
  -- "$root/examples.blend" | grep "examples written"
