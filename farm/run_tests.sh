#!/usr/bin/env bash
# Tests of the Flamenco job type: compiles jobs in Node (>= 20, built-in test runner, no npm
# packages) against stand-ins for Flamenco's job-compiler API. Exits with the runner's status.
# With an argument, also writes a JUnit report there (build/test.sh adds it to the summary).
set -uo pipefail
here=$(cd "$(dirname "$0")" && pwd)
# build/setup.sh puts a Node 20 here when the system's is older.
[ -x "$here/../build/_work/node/bin/node" ] && PATH="$here/../build/_work/node/bin:$PATH"
command -v node >/dev/null || { echo "farm/run_tests.sh: node not found (run build/setup.sh)" >&2; exit 1; }
major=$(node -p 'process.versions.node.split(".")[0]')
[ "$major" -ge 20 ] || { echo "farm/run_tests.sh: node $(node --version) is too old, need >= 20 (run build/setup.sh)" >&2; exit 1; }
reporters=(--test-reporter=spec --test-reporter-destination=stdout)
if [ $# -ge 1 ]; then
  reporters+=(--test-reporter=junit "--test-reporter-destination=$1")
fi
# The test files by name: Node >= 21 reads --test arguments as globs, not folders.
node --test "${reporters[@]}" "$here"/flamenco/test/*.test.js
