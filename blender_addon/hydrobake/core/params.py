"""Effect settings: the library describes every params struct field by field (name, type,
range, unit, description). From that one table the binding builds its ctypes mirror, checks it
against the library's layout, converts to and from plain dicts, and the addon builds its
Blender properties. Nothing about a parameter is written twice."""
import ctypes
from dataclasses import dataclass

from . import _lib, errors
from ._lib import Message, P, ParamInfo

F32, I32, U64, BOOL, ENUM = 1, 2, 3, 4, 5
_CTYPE = {F32: ctypes.c_float, I32: ctypes.c_int32, U64: ctypes.c_uint64,
          BOOL: ctypes.c_int32, ENUM: ctypes.c_int32}


@dataclass(frozen=True)
class Param:
    name: str
    type: int
    count: int
    min: float
    max: float
    unit: str
    items: tuple
    description: str
    default: object


class ParamSpec:
    """The settings of one kernel, read from its ``hbk_<x>_params_info`` table.

    ``spec.struct`` is the ctypes mirror; ``spec.params`` the Param list in C order."""

    def __init__(self, prefix):
        self.prefix = prefix
        lib = _lib.lib
        info = getattr(lib, f"hbk_{prefix}_params_info")
        info.restype, info.argtypes = P(ParamInfo), [P(ctypes.c_size_t)]
        default = getattr(lib, f"hbk_{prefix}_params_default")
        default.restype, default.argtypes = None, [ctypes.c_void_p]
        count = ctypes.c_size_t()
        table = info(ctypes.byref(count))
        self._table, self._count = table, count.value
        rows = [table[i] for i in range(count.value)]

        # The size field comes first; the struct's true size is what the defaults write there.
        probe = (ctypes.c_uint8 * 65536)()
        default(probe)
        c_size = ctypes.c_uint32.from_buffer(probe).value

        fields = [("size", ctypes.c_uint32)]
        for row in sorted(rows, key=lambda r: r.offset):
            ctype = _CTYPE[row.type] * row.count if row.count > 1 else _CTYPE[row.type]
            fields.append((row.name.decode(), ctype))
        self.struct = type(f"hbk_{prefix}_params_t", (ctypes.Structure,), {"_fields_": fields})
        if ctypes.sizeof(self.struct) != c_size:
            raise errors.VersionMismatch(
                f"hbk_{prefix}_params_t: sizeof is {c_size} in {_lib.path}, "
                f"{ctypes.sizeof(self.struct)} in the binding's mirror")
        for row in rows:
            if getattr(self.struct, row.name.decode()).offset != row.offset:
                raise errors.VersionMismatch(
                    f"hbk_{prefix}_params_t.{row.name.decode()}: offset {row.offset} in the "
                    "library differs from the binding's mirror")
        defaults = self.struct.from_buffer_copy(bytes(probe)[:c_size])
        self.params = []
        for row in rows:
            name = row.name.decode()
            value = getattr(defaults, name)
            if row.count > 1:
                value = tuple(value)
            items = tuple(row.items.decode().split("|")) if row.items else ()
            self.params.append(Param(name, row.type, row.count, row.min, row.max,
                                     row.unit.decode() if row.unit else "", items,
                                     row.description.decode() if row.description else "", value))
        self.by_name = {p.name: p for p in self.params}
        self._default_fn = default

    def defaults(self):
        """The paper's values, as a dict."""
        return {p.name: p.default for p in self.params}

    def to_struct(self, values):
        """A validated struct from a dict (missing keys keep their defaults).

        Unknown names and out-of-range values raise InvalidArgument naming the parameter."""
        unknown = set(values) - set(self.by_name)
        if unknown:
            raise errors.InvalidArgument(
                f"{sorted(unknown)[0]}: not a parameter of {self.prefix}; known: "
                f"{', '.join(self.by_name)}")
        s = self.struct()
        self._default_fn(ctypes.byref(s))
        for name, value in values.items():
            p = self.by_name[name]
            try:
                if p.count > 1:
                    if len(value) != p.count:
                        raise errors.InvalidArgument(
                            f"{name}: must have {p.count} values, got {len(value)}")
                    getattr(s, name)[:] = [self._convert(p, v, f"{name}[{k}]")
                                           for k, v in enumerate(value)]
                else:
                    setattr(s, name, self._convert(p, value, name))
            except errors.InvalidArgument:
                raise
            except (TypeError, ValueError, OverflowError) as exc:
                raise errors.InvalidArgument(f"{name} = {value!r}: {exc}") from exc
        self.validate(s)
        return s

    @staticmethod
    def _convert(p, v, label):
        if p.type == ENUM and isinstance(v, str):  # an item's name, also in an array
            if v not in p.items:
                raise errors.InvalidArgument(f"{label} = {v!r}: must be one of "
                                             f"{', '.join(p.items)}")
            return p.items.index(v)
        if p.type == F32:
            return float(v)
        if isinstance(v, float) and not v.is_integer():
            raise errors.InvalidArgument(f"{label} = {v}: must be a whole number")
        v = int(v)
        if p.type == U64 and not 0 <= v < 2**64:
            raise errors.InvalidArgument(f"{label} = {v}: must be in [0, 2^64)")
        if p.type != U64 and not -2**31 <= v < 2**31:
            raise errors.InvalidArgument(f"{label} = {v}: must be in [{p.min:g}, {p.max:g}]")
        return v

    def validate(self, s):
        """The library's own range checks (raises InvalidArgument with its message)."""
        _lib.lib.hbk_params_validate(ctypes.byref(s), ctypes.sizeof(s), self._table, self._count,
                                     Message())

    def to_dict(self, s):
        out = {}
        for p in self.params:
            v = getattr(s, p.name)
            out[p.name] = tuple(v) if p.count > 1 else v
        return out
