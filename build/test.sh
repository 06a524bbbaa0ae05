#!/usr/bin/env bash
# Sets up, builds, packages, then runs every test: C units (ctest), the same C units and the
# binding's tests again on a library built with AddressSanitizer and UBSan, the Flamenco job
# type (node), the binding from plain Python (pytest), and real Blender in background mode and
# in its UI with the packaged addon (pytest).
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

echo "== C unit tests and the binding, with AddressSanitizer and UBSan"
# A second tree: an out-of-bounds access, use after free, leak or undefined behaviour in the
# core fails the test that met it, where the optimised build might pass by chance.
san="$work/cmake-sanitize"
if cmake -S "$root/c_core" -B "$san" -DCMAKE_BUILD_TYPE=Release -DHBK_SANITIZE=ON \
     >"$work/cmake-sanitize.log" 2>&1 &&
   cmake --build "$san" -j"$(nproc)" >>"$work/cmake-sanitize.log" 2>&1; then # every test's program
  (cd "$san" && ASAN_OPTIONS=detect_leaks=1:allocator_may_return_null=1 \
     ctest --output-on-failure --output-junit "$work/junit-ctest-sanitize.xml" -j2)
  # Python itself is not instrumented: the runtime is preloaded, and leaks (the
  # interpreter's own) are not checked.
  (cd "$root" && HYDROBAKE_LIB="$san/libhydrobake.so" ASAN_OPTIONS=detect_leaks=0 \
     LD_PRELOAD="$(gcc -print-file-name=libasan.so) $(gcc -print-file-name=libubsan.so)" \
     /usr/bin/python3 -m pytest -q -p no:cacheprovider \
     --junitxml="$work/junit-pytest-sanitize.xml" tests/python | tail -n 3)
else
  echo "sanitizer build failed: see $work/cmake-sanitize.log"
  tail -n 20 "$work/cmake-sanitize.log"
  exit 1
fi

echo "== Flamenco job type (node --test)"
if ! "$root/farm/run_tests.sh" "$work/junit-node.xml" | tail -n 12 &&
   [ ! -s "$work/junit-node.xml" ]; then  # it did not run: a failure the summary must count
  cat >"$work/junit-node.xml" <<'XML'
<testsuite name="farm" tests="1" failures="1"><testcase classname="farm" name="run_tests"><failure message="farm/run_tests.sh ran no test (its error is above)"/></testcase></testsuite>
XML
fi

echo "== binding and Blender tests (pytest)"
cd "$root"
/usr/bin/python3 -m pytest -q -p no:cacheprovider --junitxml="$work/junit-pytest.xml" \
  tests/python tests/blender "$@"

/usr/bin/python3 "$root/build/summarize_junit.py" "$work"/junit-*.xml
