"""Runs the batch command line with the fixture effect registered."""
import in_blender
import fixture_wave

in_blender.enable()
fixture_wave.install()
from hydrobake.blender import cli  # noqa: E402

cli.main()
