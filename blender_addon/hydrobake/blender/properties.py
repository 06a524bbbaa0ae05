"""Blender properties built from the C parameter tables, one PropertyGroup per effect.

Each effect's settings live on the object it applies to (``obj.hydrobake_<effect>``), beside
the framework's own: enabled, cache folder, frame range and bake state."""

import bpy

from ..core import params as P
from . import paths

# Parameters that are not artistic settings: the thread count is chosen per run
# (scene setting / command line), never stored with the effect.
HIDDEN = {"threads"}

# C unit -> (Blender subtype, Blender unit). Units Blender has no subtype for stay NONE, and
# the unit is spelled out in the tooltip.
_UNITS = {
    "m": ("DISTANCE", "LENGTH"),
    "m/s": ("NONE", "VELOCITY"),
    "m/s^2": ("NONE", "ACCELERATION"),
    "rad": ("ANGLE", "ROTATION"),
    "s": ("TIME_ABSOLUTE", "TIME_ABSOLUTE"),
    "degC": ("TEMPERATURE", "TEMPERATURE"),
    "%": ("PERCENTAGE", "NONE"),
    "1/m": ("NONE", "NONE"),
}


def label_of(name):
    return name.replace("_", " ").title()


def _tooltip(p):
    unit = f" [{p.unit}]" if p.unit and p.unit != "1" else ""
    return f"{p.description}{unit}. Range {p.min:g} to {p.max:g}"


def property_for(p):
    """The bpy property for one Param, with its range, unit and tooltip."""
    common = dict(name=label_of(p.name), description=_tooltip(p))
    if p.type == P.F32:
        subtype, unit = _UNITS.get(p.unit, ("NONE", "NONE"))
        rng = dict(min=p.min, max=p.max, soft_min=p.min, soft_max=p.max)
        if p.count > 1:
            # Spatial vectors get their subtype (and X/Y/Z labels); lists of values do not.
            vsub = {"m": "TRANSLATION", "m/s": "VELOCITY", "m/s^2": "ACCELERATION"}.get(
                p.unit, "NONE") if p.count == 3 else "NONE"
            return bpy.props.FloatVectorProperty(size=p.count, default=p.default,
                                                 subtype=vsub, unit=unit, **rng, **common)
        return bpy.props.FloatProperty(default=p.default, subtype=subtype, unit=unit,
                                       precision=4, **rng, **common)
    if p.type == P.BOOL:
        return bpy.props.BoolProperty(default=bool(p.default), **common)
    if p.type == P.ENUM and p.count > 1:  # Blender has no enum arrays: indices, listed
        return bpy.props.IntVectorProperty(
            size=p.count, min=0, max=len(p.items) - 1, default=tuple(int(v) for v in p.default),
            name=common["name"], description=common["description"] + ". Values: " + ", ".join(
                f"{i} = {it}" for i, it in enumerate(p.items)))
    if p.type == P.ENUM:
        items = [(it.upper().replace(" ", "_"), it, "") for it in p.items]
        return bpy.props.EnumProperty(items=items, default=items[int(p.default)][0], **common)
    # I32 / U64: Blender ints are 32-bit signed, so u64 seeds are offered in [0, 2^31).
    lo, hi = max(p.min, -2**31), min(p.max, 2**31 - 1)
    if p.count > 1:
        return bpy.props.IntVectorProperty(size=p.count, min=int(lo), max=int(hi),
                                           default=tuple(int(v) for v in p.default), **common)
    return bpy.props.IntProperty(default=int(min(max(p.default, lo), hi)), min=int(lo),
                                 max=int(hi), **common)


def _group_to_dict(spec, pg):
    out = {}
    for p in spec.params:
        if p.name in HIDDEN:
            continue
        v = getattr(pg, p.name)
        if p.type == P.ENUM and p.count == 1:
            v = [it.upper().replace(" ", "_") for it in p.items].index(v)
        elif p.count > 1:
            v = tuple(v)
        out[p.name] = v
    return out


def to_params(groups, settings):
    """{group: {param: value}} held by an effect's settings (groups: name -> ParamSpec)."""
    return {g: _group_to_dict(spec, getattr(settings, g)) for g, spec in groups.items()}


def from_params(groups, settings, values):
    """Sets an effect's settings from {group: {param: value}} (presets, manifests)."""
    for g, group_values in values.items():
        spec, pg = groups[g], getattr(settings, g)
        for name, v in group_values.items():
            p = spec.by_name.get(name)
            if p is None or name in HIDDEN:
                continue
            if p.type == P.ENUM and p.count == 1 and isinstance(v, int):
                v = p.items[v].upper().replace(" ", "_")
            setattr(pg, name, v)


def _bake_folder_get(self):
    # Scripts read an absolute folder; the file keeps it as it was set, '//' ones relative
    # (paths.stored), so a project moved with its bakes still finds them, and with the
    # folder they are relative to, so a file saved elsewhere does too (paths.resolve).
    raw = self.get("bake_folder", "")
    return paths.resolve(raw, self.get(paths.BAKE_BASE), self.id_data.library) if raw else ""


def _bake_folder_set(self, value):
    paths.record(self, "bake_folder", value, paths.BAKE_BASE)


def make_settings_classes(effect_name, groups, extra=None):
    """PropertyGroup classes for an effect, in registration order: one per parameter group
    (built from its C table), then the effect's settings holding them plus the framework's
    bake settings."""
    classes, ann = [], {}
    for g, spec in groups.items():
        cls = type(f"HYDROBAKE_PG_{effect_name}_{g}", (bpy.types.PropertyGroup,), {
            "__annotations__": {p.name: property_for(p) for p in spec.params
                                if p.name not in HIDDEN},
            "__doc__": f"{label_of(effect_name)} {g} parameters"})
        classes.append(cls)
        ann[g] = bpy.props.PointerProperty(type=cls)
    ann.update(
        enabled=bpy.props.BoolProperty(
            name="Enabled", default=False,
            description=f"Bake the {label_of(effect_name)} effect for this object"),
        cache_dir=bpy.props.StringProperty(
            name="Cache Folder", subtype="DIR_PATH", default="//hydrobake_cache/",
            description="Folder for baked files; '//' is relative to the .blend. Each .blend, "
                        "object and effect gets its own subfolder"),
        use_scene_range=bpy.props.BoolProperty(
            name="Scene Frame Range", default=True,
            description="Bake the scene's frame range instead of the range below"),
        frame_start=bpy.props.IntProperty(name="Start", default=1, min=0, max=1048574,
                                          description="First frame to bake"),
        frame_end=bpy.props.IntProperty(name="End", default=50, min=0, max=1048574,
                                        description="Last frame to bake"),
        is_baked=bpy.props.BoolProperty(
            name="Baked", default=False,
            description="A bake exists; settings are locked until it is freed"),
        bake_folder=bpy.props.StringProperty(
            name="Bake Folder", subtype="DIR_PATH", default="", get=_bake_folder_get,
            set=_bake_folder_set,
            description="Where the current bake was written (kept relative to the .blend "
                        "when the cache folder is, read as an absolute path)"),
    )
    ann.update(extra or {})  # the effect's own scene links (ground object, sun, ...)
    classes.append(type(f"HYDROBAKE_PG_{effect_name}", (bpy.types.PropertyGroup,),
                        {"__annotations__": ann,
                         "__doc__": f"{label_of(effect_name)} settings"}))
    return classes


class HydrobakeSceneSettings(bpy.types.PropertyGroup):
    """Scene-wide settings: how many threads a bake uses (results do not depend on it)."""
    threads: bpy.props.IntProperty(
        name="Threads", default=0, min=0, max=256,
        description="Threads for baking; 0 uses every core. Results are identical for any "
                    "thread count")
