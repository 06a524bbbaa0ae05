"""Tests that run real Blender in background mode with the addon installed from its zip.

A session fixture installs dist/hydrobake-*.zip into a private user-scripts folder (so the
machine's own Blender setup is never touched); each test then runs one script under
``blender -b --factory-startup --python-exit-code 1`` and checks its exit code and output."""
import os
import shutil
import subprocess

import pytest

from hydrobake_paths import ROOT, addon_zip

SCRIPTS = os.path.join(os.path.dirname(os.path.abspath(__file__)), "scripts")
BLENDER = shutil.which("blender") or "/usr/bin/blender"


class Blender:
    def __init__(self, home):
        self.home = home
        self.env = dict(os.environ, BLENDER_USER_SCRIPTS=os.path.join(home, "scripts"),
                        BLENDER_USER_CONFIG=os.path.join(home, "config"),
                        PYTHONPATH=SCRIPTS, PYTHONDONTWRITEBYTECODE="1")
        self.env.pop("HYDROBAKE_LIB", None)  # the installed addon must find its own library
        # Unless told to use another build, e.g. the sanitized one (see README, Tests).
        if os.environ.get("HBK_BLENDER_TEST_LIB"):
            self.env["HYDROBAKE_LIB"] = os.environ["HBK_BLENDER_TEST_LIB"]

    def run(self, script, *args, blend=None, check=True, timeout=300, extra=(), cwd=None):
        cmd = [BLENDER, "-b"] + ([blend] if blend else []) + [
            "--factory-startup", "--python-exit-code", "1", *extra,
            "--python", os.path.join(SCRIPTS, script), "--", *map(str, args)]
        r = subprocess.run(cmd, env=self.env, capture_output=True, text=True, timeout=timeout,
                           cwd=cwd)
        if check and r.returncode != 0:
            pytest.fail(f"{script} exited {r.returncode}\n--- stdout\n{r.stdout[-6000:]}\n"
                        f"--- stderr\n{r.stderr[-6000:]}")
        return r

    def run_ui(self, script, *args, timeout=180):
        """Runs ``script`` in Blender's real UI on a virtual X display, with simulated events
        (--enable-event-simulate: the window takes only events the script sends)."""
        cmd = ["xvfb-run", "-a", "-s", "-screen 0 1024x700x24", BLENDER, "--factory-startup",
               "--enable-event-simulate", "--python-exit-code", "1",
               "--python", os.path.join(SCRIPTS, script), "--", *map(str, args)]
        r = subprocess.run(cmd, env=self.env, capture_output=True, text=True, timeout=timeout)
        if r.returncode != 0:
            pytest.fail(f"{script} (UI) exited {r.returncode}\n--- stdout\n{r.stdout[-6000:]}"
                        f"\n--- stderr\n{r.stderr[-6000:]}")
        return r

    def popen(self, script, *args, blend=None):
        cmd = [BLENDER, "-b"] + ([blend] if blend else []) + [
            "--factory-startup", "--python-exit-code", "1",
            "--python", os.path.join(SCRIPTS, script), "--", *map(str, args)]
        return subprocess.Popen(cmd, env=self.env, stdout=subprocess.PIPE,
                                stderr=subprocess.PIPE, text=True)


@pytest.fixture(scope="session")
def blender(tmp_path_factory):
    home = str(tmp_path_factory.mktemp("blender_home"))
    b = Blender(home)
    r = b.run("install_addon.py", addon_zip())
    assert "HYDROBAKE INSTALLED" in r.stdout, r.stdout
    return b
