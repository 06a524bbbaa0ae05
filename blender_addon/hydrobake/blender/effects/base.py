"""The Blender half of an effect: scene inputs in, baked outputs wired back."""
import fnmatch
import warnings

import bpy

from ..bridge import materials


class BakeWarning(UserWarning):
    """What prepare can bake but the artist should hear of (an overlapping UV map): Job
    collects them, the Bake operator and the command line report them before the bake."""


def warn_uv_overlap(obj, uvs, consequence, limit=0.01):
    """A BakeWarning when more than ``limit`` of what the object's UV map covers is covered
    by two or more faces (mirrored or stacked islands): ``consequence`` says what shows."""
    from ...core import image
    share = image.uv_overlap(uvs)
    if share > limit:
        layer = obj.data.uv_layers.active
        warnings.warn(f"{obj.name}: {100 * share:.0f}% of UV map "
                      f"'{layer.name if layer else ''}' is shared by two or more faces; "
                      f"{consequence}", BakeWarning)
    return share


def offers(takes):
    """Marks a PointerProperty's poll with what it takes ("a sun lamp"), for the error
    ``unoffered`` gives: Python's setattr skips a poll, so a script, an override or a file made
    elsewhere can set what the panel would never offer."""
    def mark(poll):
        poll.takes = takes
        return poll
    return mark


def poll_of(group, attr):
    """The poll of ``group``'s data-block setting ``attr`` (None without one): kept in the
    registered class's annotation, not in its RNA."""
    deferred = getattr(type(group), "__annotations__", {}).get(attr)
    return getattr(deferred, "keywords", {}).get("poll")


def unoffered(group):
    """The error for the first data-block setting of ``group`` (or of its groups) that holds
    what its poll refuses, else None. Items of a collection (a fluid's sample textures) are
    the effect's to check, with the item's number in the message."""
    for attr in getattr(type(group), "__annotations__", {}):
        value = getattr(group, attr, None)
        if isinstance(value, bpy.types.PropertyGroup):
            found = unoffered(value)
        else:
            poll = poll_of(group, attr)
            found = None
            if value is not None and poll is not None and not poll(group, value):
                label = group.bl_rna.properties[attr].name
                found = (f"{label}: {value.name} cannot be the {label}, which takes "
                         f"{getattr(poll, 'takes', 'what the panel offers')}")
        if found:
            return found
    return None


class BlenderEffect:
    name = ""           # the core effect's name
    label = ""          # shown in the UI
    icon = "MOD_FLUIDSIM"
    object_types = {"MESH"}
    presets = {}        # preset name -> parameter dict (partial)
    refracts = False    # its bake makes a surface one sees through (EEVEE: ui)
    description = ""

    @classmethod
    def core_class(cls):
        from ...core import effects
        return effects.get(cls.name)

    @classmethod
    def poll(cls, obj):
        return obj is not None and obj.type in cls.object_types

    @staticmethod
    def extra_classes():
        """Classes the effect's settings refer to (registered before them)."""
        return ()

    @classmethod
    def register_extra(cls):
        """Registers what the effect keeps elsewhere (e.g. per-material settings)."""

    @classmethod
    def unregister_extra(cls):
        """Undoes register_extra."""

    @classmethod
    def after_deletes(cls):
        """After objects were deleted (not freed first): what of their bakes other objects
        still show, and no object records now, goes."""

    @classmethod
    def extra_properties(cls):
        """Blender-only settings beside the kernels' parameters: {name: bpy property}."""
        return {}

    @classmethod
    def prepare(cls, context, obj, settings, params, frames):
        """Main thread, before the bake: returns (params, inputs) for the core effect.
        ``params`` ({group: {name: value}}) may be adjusted from the scene (e.g. the grid
        size from the object's dimensions); ``inputs`` holds arrays read from the scene. One
        that steps the scene through frames is a generator (``yield from
        animation.per_frame(...)``) returning them: the Job steps it, a frame at a time."""
        return params, {}

    @classmethod
    def apply(cls, context, obj, settings, folder, manifest):
        """Wires a finished (or partly finished) bake into the scene. Main thread."""

    @classmethod
    def remove(cls, context, obj, settings):
        """Undoes ``apply`` (Free Bake). Main thread. What apply named after the object is
        found under baked_name: the object may have been renamed since."""

    @classmethod
    def let_go(cls, context, obj, settings, keep):
        """Undoes what ``apply`` changed on this object alone (its modifiers, flags, and the
        materials not in ``keep``, which other objects recording the same bake show), when it
        lets go of a bake record others hold (a Shift+D copy's Free). Main thread."""

    @staticmethod
    def baked_name(obj, settings):
        """The object's name when its bake was wired (jobs.finalize records it)."""
        return settings.get("baked_as") or obj.name

    wired_prefix = ""   # the role of the Hydrobake nodes apply adds to materials: "snow."
    wired_streams = ()  # the images they show: HBK_<baked_name>_<stream>
    made_material = ""  # the role of the material apply makes for an object with none: "snow"

    @classmethod
    def made_material_name(cls, name):
        """The material apply makes for the object ``name`` when it has none to wire; Free
        Bake passes the baked_name to find the same one (one spelling for both)."""
        return f"HBK_{name}_{cls.made_material}"

    @classmethod
    def shown_in(cls, mats=None):
        """The baked_names whose images the materials (default: the file's) show."""
        return materials.shown_bakes(cls.wired_prefix, cls.wired_streams, mats) \
            if cls.wired_streams else set()

    @classmethod
    def slot_materials(cls, obj, settings):
        """The materials in the object's slots this bake may have wired: not one whose nodes
        show only other bakes' images (a baked object's material the artist gave this one:
        Link Materials, Join). That bake's own Free takes its wiring out, or Remove Deleted
        Objects' Bakes (monkey --scene --external 900)."""
        name = cls.baked_name(obj, settings)
        mats = {s.material for s in obj.material_slots if s.material is not None}
        shown = {m: cls.shown_in([m]) for m in mats}
        return {m for m in mats if not shown[m] or name in shown[m]}

    @classmethod
    def wired_names(cls):
        """The baked_names whose wiring (or helper objects) apply left in the file."""
        return cls.shown_in()

    @classmethod
    def forget(cls, name):
        """Undoes what ``apply`` left outside the object for the bake wired under ``name``,
        whose object was deleted while baked (not freed first). Main thread."""

    @classmethod
    def deleted_bakes(cls, names=None):
        """Of the bakes wired in the file (or of ``names``), those no object records: their
        object was deleted while baked (not freed first), and their wiring goes on showing
        them in the materials it left, which may be given to other objects, with no Free Bake
        to take it out."""
        gone = set(cls.wired_names() if names is None else names)
        if gone:
            attr = f"hydrobake_{cls.name}"
            gone -= {cls.baked_name(o, getattr(o, attr)) for o in bpy.data.objects
                     if getattr(o, attr).is_baked}
        return gone

    @classmethod
    def forget_deleted(cls):
        """Takes the deleted objects' bakes out of the file (Remove Deleted Bakes, an
        operator: its own undo step, where a handler's change after a delete would not be
        undone with it). Their files stay, as any deleted object's bake. Returns the
        names."""
        gone = cls.deleted_bakes()
        for name in sorted(gone):
            cls.forget(name)
        return gone

    @classmethod
    def forget_dropped_made(cls):
        """When a file opens: a material apply made for an object with none (known by its
        name) that no object's bake of the effect is named for, no copy stands for and
        nothing wires. Its object was deleted while baked, and the save dropped the object's
        copy that held the wiring: the one record Remove Deleted Objects' Bakes would have
        found. It goes from the Alt+D copies' slots it was left in (every flag +
        --relations 159)."""
        if not cls.made_material:
            return
        attr = f"hydrobake_{cls.name}"
        claimed = {cls.made_material_name(cls.baked_name(o, getattr(o, attr)))
                   for o in bpy.data.objects if getattr(o, attr).is_baked}
        pattern = cls.made_material_name("*")
        for mat in [m for m in bpy.data.materials if m.name not in claimed and
                    fnmatch.fnmatchcase(m.name, pattern)]:
            if materials.unrecorded_made(mat):
                materials.let_go_deleted_made(mat, cls.wired_prefix)

    @classmethod
    def evaluated_inputs(cls, obj, settings):
        """[(setting, object)] of the objects prepare reads as Blender evaluated them (the
        setting None for ``obj`` itself): the panel names any its view layer leaves out, which
        the Bake would refuse (bridge.depsgraph.evaluated_object)."""
        return []

    @classmethod
    def wired_objects(cls, obj, settings):
        """The objects whose meshes and materials apply changes to wire the bake in: the
        object itself unless the effect wires objects of its own."""
        return [obj]

    @classmethod
    def derived(cls, settings):
        """{"group.name": why} of the parameters that prepare sets itself from other
        settings, as snow's Auto Volume sets the volume and the flake count: drawn inactive,
        and refused as command-line overrides (they would be replaced without a word)."""
        return {}

    @classmethod
    def draw_settings(cls, layout, settings):
        """Draws the effect's settings; the default draws every parameter in table order."""
        from .. import properties
        derived = cls.derived(settings)
        for g, spec in cls.core_class().groups().items():
            col = layout.column()
            col.label(text=properties.label_of(g))
            pg = getattr(settings, g)
            for p in spec.params:
                if p.name not in properties.HIDDEN:
                    row = col.row()
                    row.active = f"{g}.{p.name}" not in derived
                    row.prop(pg, p.name)
