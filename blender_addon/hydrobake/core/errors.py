"""Result codes of libhydrobake as Python exceptions.

Every exception carries the library's detail message, which names the parameter and the
allowed range: ``InvalidArgument("wind_speed = -3: must be in [0, 50] m/s")``.
"""

OK = 0
INVALID_ARGUMENT = 1
OUT_OF_MEMORY = 2
IO = 3
FORMAT = 4
CANCELLED = 5
VERSION = 6
STATE = 7
INTERNAL = 8


class HydrobakeError(Exception):
    """Base of every error raised by Hydrobake. ``code`` is the C result code."""

    code = INTERNAL

    def __init__(self, message="", code=None):
        super().__init__(message)
        if code is not None:
            self.code = code


class InvalidArgument(HydrobakeError, ValueError):
    code = INVALID_ARGUMENT


class OutOfMemory(HydrobakeError, MemoryError):
    code = OUT_OF_MEMORY


class FileIOError(HydrobakeError, OSError):
    code = IO


class FormatError(HydrobakeError):
    code = FORMAT


class Cancelled(HydrobakeError):
    code = CANCELLED


class VersionMismatch(HydrobakeError):
    code = VERSION


class StateError(HydrobakeError):
    code = STATE


class LibraryNotFound(HydrobakeError, ImportError):
    """libhydrobake.so could not be found or loaded."""


_BY_CODE = {cls.code: cls for cls in (InvalidArgument, OutOfMemory, FileIOError, FormatError,
                                      Cancelled, VersionMismatch, StateError)}


def from_code(code, message):
    """The exception for a result code, with the detail message."""
    cls = _BY_CODE.get(code, HydrobakeError)
    return cls(message, code) if cls is HydrobakeError else cls(message)
