"""Loads libhydrobake and declares every C signature once, from tables.

The library is found at, in order: the path in the environment variable HYDROBAKE_LIB, then
``lib/libhydrobake.so`` inside this addon. Result codes become exceptions (see errors.py)
carrying the detail message the library wrote for the failing call.
"""
import ctypes
import os

from . import errors

ENV_VAR = "HYDROBAKE_LIB"
LIB_NAME = "libhydrobake.so"

hbk_result_t = ctypes.c_int32


class Message(ctypes.Structure):
    """hbk_message_t: the detail of a call that has no handle."""
    _fields_ = [("text", ctypes.c_char * 256)]

    def __str__(self):
        return self.text.decode("utf-8", "replace")


class Progress(ctypes.Structure):
    """hbk_progress_t: set ``cancel`` from any thread; the library writes ``fraction``."""
    _fields_ = [("cancel", ctypes.c_int32), ("fraction", ctypes.c_float)]


class ParamInfo(ctypes.Structure):
    _fields_ = [("name", ctypes.c_char_p), ("type", ctypes.c_int32), ("offset", ctypes.c_uint32),
                ("count", ctypes.c_uint32), ("min", ctypes.c_double), ("max", ctypes.c_double),
                ("unit", ctypes.c_char_p), ("items", ctypes.c_char_p),
                ("description", ctypes.c_char_p)]


class Image(ctypes.Structure):
    """hbk_image_t: a view of a caller-owned float32 buffer (row 0 = bottom)."""
    _fields_ = [("data", ctypes.POINTER(ctypes.c_float)), ("width", ctypes.c_int32),
                ("height", ctypes.c_int32), ("channels", ctypes.c_int32),
                ("row_stride", ctypes.c_size_t)]


class ExrChannel(ctypes.Structure):
    _fields_ = [("name", ctypes.c_char_p), ("data", ctypes.POINTER(ctypes.c_float)),
                ("pixel_stride", ctypes.c_size_t), ("row_stride", ctypes.c_size_t),
                ("half", ctypes.c_int32)]


def library_path():
    """Where the library is looked for (the override first)."""
    override = os.environ.get(ENV_VAR)
    if override:
        return override
    return os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "lib",
                        LIB_NAME)


def _load():
    path = library_path()
    if not os.path.isfile(path):
        raise errors.LibraryNotFound(
            f"{LIB_NAME} not found at {path}: build it with build/build.sh, or set "
            f"{ENV_VAR} to its path")
    try:
        return ctypes.CDLL(path), path
    except OSError as exc:
        raise errors.LibraryNotFound(f"cannot load {path}: {exc}") from exc


lib, path = _load()


# --- result checking ------------------------------------------------------------------------

def check_message(result, func, args):
    """errcheck for calls that take an hbk_message_t*, passed as a Message instance."""
    if result != errors.OK:
        # Callers pass the Message itself (ctypes takes its address), so it is in args.
        detail = next((str(a) for a in args if isinstance(a, Message)), "")
        raise errors.from_code(result, detail or f"{func.__name__}: {_name(result)}")
    return result


def check_handle(message_func):
    """errcheck for calls on a handle: the detail is read from the handle (args[0])."""
    def check(result, func, args):
        if result != errors.OK:
            detail = message_func(args[0]).decode("utf-8", "replace")
            raise errors.from_code(result, detail or f"{func.__name__}: {_name(result)}")
        return result
    return check


def _name(result):
    return lib.hbk_result_string(result).decode()


def declare(table):
    """Declares signatures: rows of (name, restype, argtypes[, errcheck])."""
    for row in table:
        name, restype, argtypes = row[:3]
        try:
            func = getattr(lib, name)
        except AttributeError as exc:
            raise errors.LibraryNotFound(
                f"{path} has no symbol {name}: the library is older than this addon; "
                "rebuild it") from exc
        func.restype = restype
        func.argtypes = argtypes
        if len(row) > 3 and row[3] is not None:
            func.errcheck = row[3]


P = ctypes.POINTER
declare([
    ("hbk_result_string", ctypes.c_char_p, [hbk_result_t]),
    ("hbk_version_string", ctypes.c_char_p, []),
    ("hbk_layout", hbk_result_t, [ctypes.c_char_p, ctypes.c_char_p, P(ctypes.c_size_t)]),
    ("hbk_params_validate", hbk_result_t,
     [ctypes.c_void_p, ctypes.c_size_t, P(ParamInfo), ctypes.c_size_t, P(Message)],
     check_message),
    ("hbk_grid_to_xyz", hbk_result_t,
     [P(ctypes.c_float), P(ctypes.c_float), ctypes.c_int32, ctypes.c_int32, ctypes.c_int32,
      ctypes.c_int32, ctypes.c_int32, P(Message)], check_message),
])


def layout(struct_name, field=None):
    """sizeof (field None) or offsetof in the library's own compilation."""
    out = ctypes.c_size_t()
    if lib.hbk_layout(struct_name.encode(), field.encode() if field else None,
                      ctypes.byref(out)) != errors.OK:
        raise errors.VersionMismatch(f"library does not know {struct_name}.{field}")
    return out.value


def check_mirror(cls, c_name):
    """Raises VersionMismatch if a ctypes mirror disagrees with the C struct's layout."""
    if ctypes.sizeof(cls) != layout(c_name):
        raise errors.VersionMismatch(
            f"{c_name}: sizeof is {layout(c_name)} in {path}, {ctypes.sizeof(cls)} in the binding")
    for fname, *_ in cls._fields_:
        if getattr(cls, fname).offset != layout(c_name, fname):
            raise errors.VersionMismatch(f"{c_name}.{fname}: offset differs between {path} and "
                                         "the binding")


for _cls, _cname in ((Message, "hbk_message_t"), (Progress, "hbk_progress_t"),
                     (ParamInfo, "hbk_param_info_t"), (Image, "hbk_image_t"),
                     (ExrChannel, "hbk_exr_channel_t")):
    check_mirror(_cls, _cname)

version = lib.hbk_version_string().decode()
