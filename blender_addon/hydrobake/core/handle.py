"""Base of the Python objects that own a C simulation handle (hbk_<x>_t)."""
import ctypes
import weakref

import numpy as np

from . import _lib, errors, params
from ._lib import Message, P, check_handle, check_message, hbk_result_t


class Owner:
    """close(), ``with`` and a weakref.finalize that frees the C object (never __del__).
    Subclasses call ``_own(handle, free)`` once the C object exists."""

    def _own(self, handle, free):
        self._h = handle
        self._finalizer = weakref.finalize(self, free, handle)

    @property
    def h(self):
        if not self._finalizer.alive:
            raise errors.StateError(f"{type(self).__name__} is closed")
        return self._h

    def close(self):
        self._finalizer()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


class Handle(Owner):
    """Owns one ``hbk_<prefix>_t``: created from a params dict, freed by close(), ``with`` or
    garbage collection (weakref.finalize, never __del__)."""

    prefix = ""
    _specs = {}

    @classmethod
    def spec(cls):
        """The kernel's ParamSpec (built once, checked against the library's layout)."""
        if cls.prefix not in Handle._specs:
            Handle._specs[cls.prefix] = params.ParamSpec(cls.prefix)
        return Handle._specs[cls.prefix]

    @classmethod
    def declare(cls, prefix, table):
        """Declares create/destroy/message for ``prefix`` plus the handle calls in ``table``:
        rows (name, argtypes after the handle); all return hbk_result_t, checked against the
        handle's own message."""
        lib = _lib.lib
        _lib.declare([
            (f"hbk_{prefix}_create", hbk_result_t,
             [P(ctypes.c_void_p), ctypes.c_void_p, P(Message)], check_message),
            (f"hbk_{prefix}_destroy", None, [ctypes.c_void_p]),
            (f"hbk_{prefix}_message", ctypes.c_char_p, [ctypes.c_void_p]),
        ])
        check = check_handle(getattr(lib, f"hbk_{prefix}_message"))
        table = list(table) + [("save_state", [ctypes.c_void_p, ctypes.c_size_t]),
                               ("load_state", [ctypes.c_void_p, ctypes.c_size_t])]
        _lib.declare([(f"hbk_{prefix}_{name}", hbk_result_t, [ctypes.c_void_p, *args], check)
                      for name, args in table])
        _lib.declare([(f"hbk_{prefix}_state_size", ctypes.c_size_t, [ctypes.c_void_p])])

    def __init__(self, values=None):
        self.params = self.spec().to_struct(values or {})
        lib = _lib.lib
        h = ctypes.c_void_p()
        getattr(lib, f"hbk_{self.prefix}_create")(ctypes.byref(h), ctypes.byref(self.params),
                                                  Message())
        self._own(h, getattr(lib, f"hbk_{self.prefix}_destroy"))

    def call(self, name, *args):
        return getattr(_lib.lib, f"hbk_{self.prefix}_{name}")(self.h, *args)

    def save_state(self):
        """The simulation's checkpoint (hbk_<x>_save_state): a read-only buffer to compare,
        slice, hash or write like bytes. Written straight into unfilled memory: a zeroed ctypes
        buffer and then a copy to bytes cost half a second a frame for the 200 MB of a 128^3
        fluid."""
        n = getattr(_lib.lib, f"hbk_{self.prefix}_state_size")(self.h)
        buf = np.empty(n, np.uint8)
        self.call("save_state", buf.ctypes.data_as(ctypes.c_void_p), n)
        return memoryview(buf).toreadonly()

    def load_state(self, data):
        """Continues from a checkpoint of a handle with the same params, bit for bit."""
        try:
            buf = np.frombuffer(data, np.uint8)  # read in place: the C side only reads it
        except (TypeError, ValueError):
            raise errors.InvalidArgument(f"data: must be a bytes-like checkpoint (save_state's), "
                                         f"got {type(data).__name__}") from None
        self.call("load_state", buf.ctypes.data_as(ctypes.c_void_p), len(buf))
