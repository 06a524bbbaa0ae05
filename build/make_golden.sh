#!/usr/bin/env bash
# Re-bakes the golden set of examples.blend (frames 1-2, test resolutions from
# tests/golden/overrides.json) into tests/golden/examples/. Run it when an effect's output
# changes on purpose, look at the regression report first, and commit the result.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
"$root/build/build.sh"
zip=$("$root/build/package.sh")
export BLENDER_USER_SCRIPTS="$root/build/_work/blender_home/scripts"
export BLENDER_USER_CONFIG="$root/build/_work/blender_home/config"
blender -b --factory-startup --python-exit-code 1 \
  --python "$root/tests/blender/scripts/install_addon.py" -- "$zip" | grep -q "HYDROBAKE INSTALLED"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
cp "$root/examples.blend" "$tmp/examples.blend"
rm -rf "$tmp/golden"
blender -b "$tmp/examples.blend" --factory-startup --python-exit-code 1 \
  --python-expr "import hydrobake.blender.cli as c; c.main()" -- \
  bake --frames 1-2 --overrides "$root/tests/golden/overrides.json" --output "$tmp/golden" \
  --no-save | grep "hydrobake:"
find "$tmp/golden" -name "checkpoint_*.bin" -delete  # resume data: not compared, not shipped
rm -rf "$root/tests/golden/examples"
mv "$tmp/golden/examples" "$root/tests/golden/examples"
du -sh "$root/tests/golden/examples"
