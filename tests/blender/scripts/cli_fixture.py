"""Runs the batch command line with the fixture effect registered."""
import hbk_test
import fixture_wave

hbk_test.enable()
fixture_wave.install()
from hydrobake.blender import cli  # noqa: E402

cli.main()
