#!/usr/bin/env bash
# Sets up, builds, packages, then runs every test: C units (ctest), the Flamenco job type
# (node), the binding from plain Python (pytest), and real Blender in background mode and in
# its UI with the packaged addon (pytest).
# Ends with one line "N passed, N failed"; exits non-zero if anything failed.
set -uo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
work="$root/build/_work"
"$root/build/setup.sh" || exit 1
"$root/build/build.sh" || exit 1
"$root/build/package.sh" >/dev/null || exit 1
rm -f "$work"/junit-*.xml

echo "== C unit tests (ctest)"
(cd "$work/cmake" && ctest --output-on-failure --output-junit "$work/junit-ctest.xml" -j2)

echo "== Flamenco job type (node --test)"
"$root/farm/run_tests.sh" "$work/junit-node.xml" | tail -n 12

echo "== binding and Blender tests (pytest)"
cd "$root"
/usr/bin/python3 -m pytest -q -p no:cacheprovider --junitxml="$work/junit-pytest.xml" \
  tests/python tests/blender "$@"

/usr/bin/python3 "$root/build/summarize_junit.py" "$work"/junit-*.xml
