"""The whole-bake benchmark refuses a bad argument before it bakes anything: exit 2, with the
argument's name and its range (the resolution's from the library's own table)."""
import os
import subprocess

import pytest

from hydrobake.core.fluid import Fluid

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
SCRIPT = os.path.join(ROOT, "build", "bench_fluid_bake.py")


def run(*args):
    return subprocess.run(["/usr/bin/python3", SCRIPT, *args], capture_output=True, text=True,
                          timeout=60)


@pytest.mark.parametrize("args, name", [(["0"], "frames"), (["x"], "frames"),
                                        (["10001"], "frames"), (["2", "3"], "resolution"),
                                        (["2", "257.5"], "resolution")])
def test_bad_argument_named_with_range(args, name):
    r = run(*args)
    res = Fluid.spec().by_name["resolution"]
    lo, hi = (1, 10000) if name == "frames" else (int(res.min), int(res.max))
    assert r.returncode == 2, r.stdout + r.stderr
    assert f"argument {name}: must be an integer in [{lo}, {hi}], got '{args[-1]}'" in r.stderr
    assert r.stdout == ""  # nothing baked, nothing timed


def test_help_lists_arguments():
    r = run("--help")
    assert r.returncode == 0 and "frames" in r.stdout and "resolution" in r.stdout
