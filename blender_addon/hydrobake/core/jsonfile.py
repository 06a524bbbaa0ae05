"""A JSON file a command-line option names (--overrides, --tolerances), read with the option
and the file's name in every error."""
import json


def read(path, option):
    """The parsed contents of ``path``; a ValueError "<option> <path>: ..." for a file that
    cannot be read or is not JSON."""
    try:
        with open(path) as f:
            return json.load(f)
    except OSError as exc:
        raise ValueError(f"{option} {path}: {exc.strerror or exc}") from None
    except ValueError as exc:  # json.JSONDecodeError, UnicodeDecodeError
        raise ValueError(f"{option} {path}: not valid JSON ({exc})") from None
