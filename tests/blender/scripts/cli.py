"""Runs the batch command line with the installed addon (as build/hydrobake-batch does)."""
import in_blender

in_blender.enable()
from hydrobake.blender import cli  # noqa: E402

cli.main()
