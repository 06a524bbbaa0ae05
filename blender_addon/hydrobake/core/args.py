"""Python arguments -> what the C calls take, checked first.

ctypes and numpy convert what they can and fail on the rest with messages that do not say
which argument was wrong (``must be real number, not str``, ``invalid index``), or convert
silently what they should not (a float index truncated, an int64 one wrapped into int32, a
short vector padded with zeros). Each helper here takes the argument's name and raises
InvalidArgument ``"{name}: must be ..."`` instead. Ranges stay the library's to check, except
int32's (ctypes wraps past it) and where numpy would allocate from the value first. numpy
scalars pass wherever Python numbers do.
"""
import ctypes
from numbers import Integral, Number, Real

import numpy as np

from . import errors
from ._lib import Progress

INT32_MIN, INT32_MAX = -2**31, 2**31 - 1


def _got(value):
    """A short description of a wrong value for a message."""
    if value is None or isinstance(value, (bool, Number, str, bytes, np.generic)):
        text = repr(value)
        return text if len(text) <= 40 else text[:37] + "..."
    if isinstance(value, np.ndarray):
        return f"an array of shape {value.shape} and dtype {value.dtype}"
    return type(value).__name__


def _scalar(value):
    """A 0-d array's element (what numpy reductions and indexing may hand back)."""
    return value[()] if isinstance(value, np.ndarray) and value.ndim == 0 else value


def number(value, name):
    """value as a Python float: a real number (int, float, numpy's), not a bool or a string.
    Infinities and NaN pass: the library's range checks name them."""
    v = _scalar(value)
    if isinstance(v, (bool, np.bool_)) or not isinstance(v, Real):
        raise errors.InvalidArgument(f"{name}: must be a number, got {_got(value)}")
    try:
        return float(v)
    except OverflowError:  # an int past float's range
        raise errors.InvalidArgument(f"{name}: must be a number within float range, got "
                                     f"{_got(value)}") from None


def integer(value, name, lo=INT32_MIN, hi=INT32_MAX):
    """value as a Python int in [lo, hi] (by default int32's range, which ctypes would wrap
    silently): an integer, or a float with an integral value; not a bool."""
    v = _scalar(value)
    if isinstance(v, (bool, np.bool_)) or not isinstance(v, Real):
        raise errors.InvalidArgument(f"{name}: must be an integer, got {_got(value)}")
    if not isinstance(v, Integral):
        f = float(v)
        if not f.is_integer():  # 1.5, NaN and inf: int() would truncate or fail unnamed
            raise errors.InvalidArgument(f"{name}: must be an integer, got {_got(value)}")
        v = f
    v = int(v)
    if not lo <= v <= hi:
        raise errors.InvalidArgument(f"{name}: must be an integer in [{lo}, {hi}], got {v}")
    return v


def flag(value, name):
    """value as 0 or 1: a bool (Python's or numpy's) or a number, non-zero being true (as a
    row of a float array holds one)."""
    v = _scalar(value)
    if not isinstance(v, (bool, np.bool_, Real)) or v != v:  # v != v: NaN
        raise errors.InvalidArgument(f"{name}: must be True or False, got {_got(value)}")
    return int(bool(v))


def choice(value, name, options):
    """value, which must be one of the strings ``options`` (a dict's keys or a sequence)."""
    if not isinstance(value, str) or value not in options:
        raise errors.InvalidArgument(f"{name}: must be one of {', '.join(options)}, got "
                                     f"{_got(value)}")
    return value


def sequence(value, name, n=None, what="items"):
    """value's items as a list: any iterable but a string, of exactly n items when n is set
    (a tuple, a list, a numpy array, a mathutils Vector)."""
    if isinstance(value, (str, bytes)) or (isinstance(value, np.ndarray) and value.ndim == 0):
        items = None
    else:
        try:
            items = list(value)
        except TypeError:
            items = None
    if items is None:
        count = f"{n} " if n is not None else ""
        raise errors.InvalidArgument(f"{name}: must be a sequence of {count}{what}, got "
                                     f"{_got(value)}")
    if n is not None and len(items) != n:
        raise errors.InvalidArgument(f"{name}: must have {n} {what}, got {len(items)}")
    return items


def numbers(value, name, n=None):
    """value as a ctypes float array: exactly n numbers when n is set (a C vector of n floats
    reads n; fewer were zero-padded by ctypes, more failed with "invalid index")."""
    items = sequence(value, name, n, "numbers")
    return (ctypes.c_float * len(items))(*[number(v, f"{name}[{k}]")
                                           for k, v in enumerate(items)])


def _array_like(value, name, what):
    if value is None or isinstance(value, (str, bytes)):
        # numpy would make None a NaN and "3" a 3.0
        raise errors.InvalidArgument(f"{name}: must be {what}, got {_got(value)}")


def _rows(a, name, columns, what):
    if columns is None:
        return a
    if a.size % columns:
        raise errors.InvalidArgument(f"{name}: must be {what} of shape (n, {columns}), got "
                                     f"shape {a.shape}")
    return a.reshape(-1, columns)


def float32_array(value, name, columns=None):
    """value as a C-contiguous float32 array (a copy only where needed), shaped (n, columns)
    when columns is set (any shape of a multiple of columns values, as before)."""
    what = "an array of numbers"
    _array_like(value, name, what)
    try:
        a = np.ascontiguousarray(value, np.float32)
    except (TypeError, ValueError) as exc:  # strings, ragged lists, objects
        raise errors.InvalidArgument(f"{name}: must be {what}, got {_got(value)}") from exc
    return _rows(a, name, columns, what)


def index_array(value, name, columns=None):
    """value as a C-contiguous int32 array of indices. An integer dtype is required (a float
    array would be truncated), and values within int32 (an int64 of 2**32 + 2 would wrap to
    2); whether an index is in range is the library's to check. An empty list passes."""
    what = "an array of integers"
    _array_like(value, name, what)
    try:
        a = np.asarray(value)
    except (TypeError, ValueError) as exc:
        raise errors.InvalidArgument(f"{name}: must be {what}, got {_got(value)}") from exc
    if a.size:
        if a.dtype == object and all(isinstance(v, Integral) and
                                     not isinstance(v, (bool, np.bool_)) for v in a.flat):
            lo, hi = min(a.flat), max(a.flat)  # Python ints past int64 make an object array
        elif np.issubdtype(a.dtype, np.integer):
            lo, hi = a.min(), a.max()
        else:
            raise errors.InvalidArgument(f"{name}: must be {what}, got dtype {a.dtype}")
        if lo < INT32_MIN or hi > INT32_MAX:
            raise errors.InvalidArgument(f"{name}: must be integers in [{INT32_MIN}, "
                                         f"{INT32_MAX}], got {lo if lo < INT32_MIN else hi}")
    return _rows(np.ascontiguousarray(a, np.int32), name, columns, what)


def progress(value):
    """A call's progress: None or a Progress (ctypes would fail with "wrong type")."""
    if value is not None and not isinstance(value, Progress):
        raise errors.InvalidArgument(f"progress: must be a Progress or None, got "
                                     f"{_got(value)}")
    return value
