#!/usr/bin/env bash
# Installs what Hydrobake needs from Debian 12's packages (as root), or prints the exact
# apt-get line and stops (otherwise), and Node 20 from the npm registry if the system's is
# older. Safe to run again: installs only what is missing.
set -euo pipefail
PKGS=(blender python3-openvdb python3-numpy python3-pytest libopenexr-dev cmake gcc make
      pkg-config xvfb xauth python3-pil nodejs)
missing=()
for p in "${PKGS[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  line="apt-get install -y --no-install-recommends ${missing[*]}"
  if [ "$(id -u)" -ne 0 ]; then
    echo "hydrobake setup: missing packages: ${missing[*]}" >&2
    echo "run as root:  apt-get update && $line" >&2
    exit 1
  fi
  echo "hydrobake setup: installing ${missing[*]}"
  export DEBIAN_FRONTEND=noninteractive
  apt-get update -qq
  apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi
# The Flamenco tests need Node >= 20 (its JUnit reporter); Debian 12's nodejs is 18. Then a
# pinned Node 20 comes from the npm registry (checked against its sha512) into build/_work,
# where farm/run_tests.sh looks first.
root=$(cd "$(dirname "$0")/.." && pwd)
if [ "$(node -p 'process.versions.node.split(".")[0]' 2>/dev/null || echo 0)" -lt 20 ]; then
  /usr/bin/python3 "$root/build/fetch_node.py" "$root/build/_work/node"
fi
