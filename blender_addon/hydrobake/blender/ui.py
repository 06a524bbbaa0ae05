"""Panels: one per effect in the Physics tab of the object it applies to, where Blender keeps
its own simulations, with Bake / Free Bake, progress, presets and the settings (greyed out
while a bake exists)."""
import bpy

from . import jobs
from .bridge import depsgraph


def draw_effect(layout, context, beffect):
    obj = context.object
    settings = jobs.settings_of(obj, beffect.name)
    layout.use_property_split = True
    layout.use_property_decorate = False
    job = jobs.running(obj, beffect.name)

    row, op = layout.row(align=True), None
    if job is None and jobs.foreign(obj):
        _draw_foreign(row, obj)
    elif job is not None:
        s = job.runner.state
        frame = s.frame if s.frame is not None else s.frame_start
        eta = s.eta()
        left = "" if eta is None else f", {int(eta) // 60}:{int(eta) % 60:02d} left"
        row.label(text=f"Baking frame {frame} / {s.frame_end} "
                       f"({job.runner.poll_fraction():.0%}{left})", icon="TIME")
        op = row.operator("hydrobake.cancel_bake", text="Cancel", icon="CANCEL")
    elif settings.is_baked:
        if jobs.bake_state(obj, beffect.name) == "PARTIAL":
            op = row.operator("hydrobake.bake", text="Resume", icon="PLAY")
            op.effect, op.object_name, op.resume = beffect.name, obj.name, True
        op = row.operator("hydrobake.free_bake", text="Free Bake", icon="TRASH")
    else:
        if jobs.unrecorded_bake(obj, beffect.name):  # a bake Blender lost track of
            op = row.operator("hydrobake.bake", text="Resume", icon="PLAY")
            op.effect, op.object_name, op.resume = beffect.name, obj.name, True
        op = row.operator("hydrobake.bake", text="Bake", icon="RENDER_ANIMATION")
    if op is not None:
        op.effect, op.object_name = beffect.name, obj.name
    _draw_deleted_bakes(layout, obj, beffect)
    if not settings.is_baked and job is None and op is not None:
        _draw_left_out(layout, context, obj, settings, beffect)
    if settings.is_baked and job is None:
        layout.label(text=f"Baked in {bpy.path.relpath(settings.bake_folder)}", icon="CHECKMARK")
        _draw_eevee_refraction(layout, context, beffect)

    locked = settings.is_baked or job is not None or jobs.foreign(obj) is not None
    col = layout.column()
    col.enabled = not locked
    col.prop(settings, "cache_dir")
    col.prop(settings, "use_scene_range")
    sub = col.column(align=True)
    sub.active = not settings.use_scene_range
    sub.prop(settings, "frame_start")
    sub.prop(settings, "frame_end")
    col.prop(context.scene.hydrobake, "threads")

    if beffect.presets:
        row = col.row(align=True)
        row.label(text="Presets")
        for name in beffect.presets:
            op = row.operator("hydrobake.apply_preset", text=name)
            op.effect, op.object_name, op.preset = beffect.name, obj.name, name
    box = col.box()
    beffect.draw_settings(box, settings)


def _draw_foreign(row, obj):
    """A linked object or library override: its library keeps its bake (see jobs.foreign)."""
    if obj.library is not None:
        row.label(text=f"Linked from {bpy.path.basename(obj.library.filepath)}: bake it "
                       "there, or Make Local", icon="LINKED")
    else:
        row.label(text="Library override: bake it in its library file, or Make Local",
                  icon="LIBRARY_DATA_OVERRIDE")


def _draw_eevee_refraction(layout, context, beffect):
    """A baked water or glass renders in EEVEE only with screen-space refraction, a scene
    setting the bake leaves to the artist: offered here where it is off."""
    ee = context.scene.eevee
    if not beffect.refracts or context.scene.render.engine != "BLENDER_EEVEE" or \
            (ee.use_ssr and ee.use_ssr_refraction):
        return
    box = layout.box()
    box.use_property_split = False
    box.label(text="EEVEE draws it opaque without screen-space refraction", icon="INFO")
    row = box.row()
    row.prop(ee, "use_ssr", text="Screen Space Reflections")
    row.prop(ee, "use_ssr_refraction", text="Refraction")


def _draw_deleted_bakes(layout, obj, beffect):
    """A material of the object shows the bake of an object deleted while baked (it was given
    that object's material): say so, with the button that takes it out."""
    shown = beffect.shown_in([s.material for s in obj.material_slots])
    shown = sorted(beffect.deleted_bakes(shown)) if shown else []
    if shown:
        row = layout.row()
        row.alert = True
        row.label(text=f"Shows the {beffect.label.lower()} of deleted "
                       f"{', '.join(repr(n) for n in shown)}", icon="ERROR")
        op = row.operator("hydrobake.remove_deleted_bakes", text="Remove")
        op.effect = beffect.name


def _draw_left_out(layout, context, obj, settings, beffect):
    """Objects the bake reads that the view layer leaves out (not evaluated), and a linked mesh
    or material it would wire: the Bake would refuse them, so say which before it is
    pressed."""
    left = [o.name if role is None else f"{role}: {o.name}"
            for role, o in beffect.evaluated_inputs(obj, settings)
            if not depsgraph.enabled(context.view_layer, o)]
    if left:
        col = layout.column(align=True)
        col.alert = True
        col.label(text=f"Not evaluated in this view layer: {', '.join(left)}", icon="ERROR")
        col.label(text="Turn on Show In > Viewports and include its collection to bake",
                  icon="BLANK1")
    linked = jobs.linked_parts(beffect, obj, settings)
    if linked:  # its first words name the part, the rest what to do
        part = linked.partition(", so ")[0]
        col = layout.column(align=True)
        col.alert = True
        col.label(text=part, icon="LINKED")
        col.label(text="Make Local > Selected Objects, Data and Materials to bake",
                  icon="BLANK1")


def make_panel(beffect):
    def poll(cls, context):
        return beffect.poll(context.object)

    def draw_header(self, context):
        self.layout.prop(jobs.settings_of(context.object, beffect.name), "enabled", text="")

    def draw(self, context):
        draw_effect(self.layout, context, beffect)

    return type(f"HYDROBAKE_PT_{beffect.name}", (bpy.types.Panel,), {
        "bl_label": f"Hydrobake {beffect.label}",
        "bl_space_type": "PROPERTIES", "bl_region_type": "WINDOW", "bl_context": "physics",
        "bl_options": {"DEFAULT_CLOSED"},
        "poll": classmethod(poll), "draw_header": draw_header, "draw": draw,
    })
