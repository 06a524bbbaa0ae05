"""Thin operators: bake (modal with progress and Esc in the UI, blocking in background mode and
from scripts), cancel, free, presets, and the removal of deleted objects' bakes."""
import functools
import time
import traceback

import bpy

from ..core import errors
from . import effects, jobs, paths, properties
from .reading_progress import step_text


def _target(context, op):
    """The object named by the operator (else the active one), or None after reporting why;
    the operator's effect must be one the addon has (a script may name any)."""
    known = effects.load_all()
    if op.effect not in known:
        op.report({"ERROR"}, f"effect = {op.effect!r}: must be one of "
                             f"{', '.join(sorted(known))}")
        return None
    obj = bpy.data.objects.get(op.object_name) if op.object_name else context.object
    if obj is None:
        op.report({"ERROR"}, f"No object named '{op.object_name}'" if op.object_name
                  else "No active object")
    return obj


class _EffectTarget:
    effect: bpy.props.StringProperty(name="Effect", description="Effect name, e.g. 'caustics'")
    object_name: bpy.props.StringProperty(
        name="Object", description="Object to bake; empty for the active object")


class HYDROBAKE_OT_bake(_EffectTarget, bpy.types.Operator):
    """Bake this effect over the frame range into the cache folder"""
    bl_idname = "hydrobake.bake"
    bl_label = "Bake"
    bl_options = {"REGISTER"}

    resume: bpy.props.BoolProperty(
        name="Resume", default=False,
        description="Continue an interrupted bake from its last good checkpoint (frames that "
                    "fail their checksum are baked again); the result equals an uninterrupted "
                    "bake. Refused if the settings, or the scene up to that checkpoint, changed")

    _job = None
    _timer = None
    _reading = None  # a UI bake's Job being made, a frame of the scene at a time
    READ_FIRST = 0.2  # s of reading in invoke: most bakes are made then, as at once
    READ_TICK = 0.15  # s of reading per timer tick after: Esc is read between ticks

    REFUSALS = (errors.HydrobakeError, paths.CacheFolderError, KeyError, ValueError)

    def _checked(self, context):
        """The object to bake, or None after reporting why not."""
        obj = _target(context, self)
        if obj is None:
            return None
        if not effects.get(self.effect).poll(obj):
            self.report({"ERROR"}, f"{obj.name} cannot have the {self.effect} effect (a "
                                   f"{obj.type.lower()})")
            return None
        try:
            if jobs.running(obj, self.effect) is not None:
                self.report({"ERROR"}, f"{obj.name}: a {self.effect} bake is already running")
                return None
        except self.REFUSALS as exc:
            self.report({"ERROR"}, f"{obj.name} {self.effect}: {exc}")
            return None
        if (obj.name, self.effect) in jobs.ACTIVE:  # and into the folder of that name
            self.report({"ERROR"}, f"{obj.name}: a {self.effect} bake of another object "
                        "first called by this name (renamed since) is running; wait for "
                        "it or cancel it")
            return None
        return obj

    def _made(self, job):
        for text in job.warnings:
            self.report({"WARNING"}, text)
        return job

    def _make_job(self, context):
        obj = self._checked(context)
        if obj is None:
            return None
        try:
            return self._made(jobs.Job(context, obj, self.effect, resume=self.resume))
        except self.REFUSALS as exc:
            self.report({"ERROR"}, f"{obj.name} {self.effect}: {exc}")
            return None

    def _read(self, seconds):
        """Steps the reading for about ``seconds``: "done" (the Job is made), "more", or
        "failed" (reported; the reading closed)."""
        reading, t0 = self._reading, time.monotonic()
        try:
            while time.monotonic() - t0 < seconds:
                if reading.step() is None:
                    reading.close()
                    return "done"
            return "more"
        except self.REFUSALS as exc:
            reading.close()
            self.report({"ERROR"}, f"{reading.label.replace('/', ' ')}: {exc}")
            return "failed"
        except BaseException:
            reading.close()
            raise

    def execute(self, context):
        """Blocking bake: background mode, scripts and the command line."""
        job = self._make_job(context)
        if job is None:
            return {"CANCELLED"}
        jobs.ACTIVE[job.key] = job
        try:
            job.runner.run()
        except (errors.HydrobakeError, OSError):
            pass  # the runner's state carries the message (a disk's too); _report shows it
        except Exception:
            traceback.print_exc()  # a bug: its place matters more than its message
        finally:
            wired = self._finalize(context, job)
        return self._report(job) if wired else {"CANCELLED"}

    def _finalize(self, context, job):
        """Records and wires the bake; an error wiring it (the object changed meanwhile,
        say into a curve) is reported, as the bake's own errors are. False then."""
        try:
            job.finalize(context)
            return True
        except Exception as exc:
            traceback.print_exc()
            self.report({"ERROR"}, f"{job.object_name} {job.effect_name}: baked, but the "
                        f"result could not be wired ({type(exc).__name__}: {exc}); Free Bake "
                        "undoes what was")
            return False

    def _notes(self, job):
        for text in job.runner.effect.notes():
            self.report({"WARNING"}, f"{job.object_name} {job.effect_name}: {text}")

    def _report(self, job):
        s = job.runner.state
        if s.status == "FINISHED":
            self.report({"INFO"}, f"Baked {s.done} frames of {job.effect_name} to {job.folder}")
            self._notes(job)
            return {"FINISHED"}
        if s.status == "CANCELLED":
            self._notes(job)
            self.report({"WARNING"}, f"Bake cancelled: frames {s.frame_start}-"
                        f"{s.frame_start + s.done - 1} are kept" if s.done else "Bake cancelled")
            return {"CANCELLED"}
        self.report({"ERROR"}, f"{job.object_name} {job.effect_name}: {s.message}")
        return {"CANCELLED"}

    def invoke(self, context, event):
        if bpy.app.background:
            return self.execute(context)
        obj = self._checked(context)
        if obj is None:
            return {"CANCELLED"}
        # A bake that steps the scene through many frames reads them from a timer, a few
        # at a time, so that Esc stops it (Blender reads no events while Python runs).
        self._reading = jobs.Job.stepwise(context, obj, self.effect, resume=self.resume)
        got = self._read(self.READ_FIRST)
        if got == "failed":
            return {"CANCELLED"}
        wm = context.window_manager
        if got == "more":
            timer = self._timer = wm.event_timer_add(0.01, window=context.window)
            window = context.window.as_pointer()
            self._reading.ui_end = lambda: _end_status(wm, timer, window)
            wm.modal_handler_add(self)
            self._reading_status(context)
            return {"RUNNING_MODAL"}
        reading, self._reading = self._reading, None
        return self._start(context, self._made(reading.job))

    def _reading_status(self, context):
        last = self._reading.last
        if last is not None:
            context.workspace.status_text_set(
                f"Hydrobake: {self._reading.label} reading the scene: {step_text(*last)} - "
                "Esc to cancel")

    def _modal_reading(self, context, event):
        """The scene being read: Esc stops it; other input waits (the scene must not change
        under the frames being read), timers go on (another bake's too)."""
        if self._reading.closed:  # stopped by cancel_all (the addon disabled)
            self._reading = None
            return {"CANCELLED"}
        if event.type == "ESC" and event.value == "PRESS":
            self._reading.close()
            self._reading = None
            self.report({"WARNING"}, "Bake cancelled while reading the scene: nothing baked")
            return {"CANCELLED"}
        if event.type != "TIMER":
            return {"RUNNING_MODAL"}
        got = self._read(self.READ_TICK)  # (closes the reading when done or failed)
        if got == "more":
            self._reading_status(context)
            return {"PASS_THROUGH"}
        reading, self._reading = self._reading, None
        if got == "failed":
            return {"CANCELLED"}
        job = self._made(reading.job)
        self._start(context, job, modal=False)
        return {"PASS_THROUGH"}

    def _start(self, context, job, modal=True):
        """The bake's thread to start at the next tick, its progress shown."""
        self._job = job
        jobs.ACTIVE[job.key] = job
        # The thread starts at the first timer tick, not here: after invoke returns, Blender
        # 3.4 still reads a caller's context override (a script's temp_override) without the
        # GIL, and the bake's thread holding it then crashed Blender (UI test, seldom).
        wm = context.window_manager
        self._timer = wm.event_timer_add(0.1, window=context.window)
        wm.progress_begin(0, 1000)
        if modal:
            wm.modal_handler_add(self)
        # Disabling the addon or opening a file cancels the bake and drops this handler
        # unasked: the progress, the status text and the timer still go then.
        job.ui_end = functools.partial(_end_progress, wm, self._timer,
                                       context.window.as_pointer())
        return {"RUNNING_MODAL"}

    def modal(self, context, event):
        if self._reading is not None:
            return self._modal_reading(context, event)
        job = self._job
        if event.type == "ESC" and event.value == "PRESS":
            job.runner.cancel()
        if event.type != "TIMER":
            return {"PASS_THROUGH"}
        if not job.runner.started:
            job.runner.start()  # (a cancel before it leaves the folder as it was)
            return {"PASS_THROUGH"}
        wm = context.window_manager
        wm.progress_update(int(job.runner.poll_fraction() * 1000))
        s = job.runner.state
        if s.frame is not None:
            context.workspace.status_text_set(
                f"Hydrobake: {job.effect_name} frame {s.frame} of {s.frame_end} "
                f"({job.runner.poll_fraction():.0%}) - Esc to cancel")
        for area in context.screen.areas:
            if area.type == "PROPERTIES":
                area.tag_redraw()
        if job.runner.is_alive():
            return {"PASS_THROUGH"}
        job.ui_end = None
        _end_progress(wm, self._timer, context.window.as_pointer())
        wired = self._finalize(context, job)
        # The record and the wiring as one undo step: without it, the next Ctrl+Z went back
        # past the bake and dropped its record, yet kept its wiring (the materials had not
        # changed between the two earlier steps), and Ctrl+Shift+Z did not bring it back.
        if bpy.ops.ed.undo_push.poll():
            bpy.ops.ed.undo_push(message=f"Hydrobake {job.effect_name} bake")
        return self._report(job) if wired else {"CANCELLED"}


def _end_status(wm, timer, window):
    """A reading's timer and status text let go (the status in the window of that pointer,
    if it is still open)."""
    wm.event_timer_remove(timer)
    win = next((w for w in wm.windows if w.as_pointer() == window), None)
    if win is not None:
        with bpy.context.temp_override(window=win):
            bpy.context.workspace.status_text_set(None)


def _end_progress(wm, timer, window):
    """A modal bake's timer, progress and status text let go."""
    wm.progress_end()
    _end_status(wm, timer, window)


class HYDROBAKE_OT_cancel_bake(_EffectTarget, bpy.types.Operator):
    """Stop the running bake; frames already baked are kept"""
    bl_idname = "hydrobake.cancel_bake"
    bl_label = "Cancel Bake"

    def execute(self, context):
        obj = _target(context, self)
        job = obj and jobs.running(obj, self.effect)
        if job is None:
            self.report({"WARNING"}, "No bake is running")
            return {"CANCELLED"}
        job.runner.cancel()
        return {"FINISHED"}


class HYDROBAKE_OT_free_bake(_EffectTarget, bpy.types.Operator):
    """Delete this bake's files (only those) and unlock the settings"""
    bl_idname = "hydrobake.free_bake"
    bl_label = "Free Bake"
    bl_options = {"REGISTER"}

    def execute(self, context):
        obj = _target(context, self)
        if obj is None:
            return {"CANCELLED"}
        if jobs.running(obj, self.effect) is not None or (obj.name, self.effect) in jobs.ACTIVE:
            self.report({"ERROR"}, "Cancel the running bake first")
            return {"CANCELLED"}
        try:
            folder = jobs.folder_of(obj, self.effect)
            removed = jobs.free(context, obj, self.effect)
        except (KeyError, paths.CacheFolderError, OSError, ValueError) as exc:
            self.report({"ERROR"}, str(exc))
            return {"CANCELLED"}
        except Exception as exc:  # unwiring failed: the bake and its record are kept
            traceback.print_exc()
            self.report({"ERROR"}, f"{obj.name} {self.effect}: could not unwire the bake "
                        f"({type(exc).__name__}: {exc}); its files and record are kept")
            return {"CANCELLED"}
        self.report({"INFO"}, f"Freed {len(removed)} files")
        kept = jobs.kept_after_free(folder)
        if kept:
            self.report({"WARNING"}, kept)
        return {"FINISHED"}


class HYDROBAKE_OT_apply_preset(_EffectTarget, bpy.types.Operator):
    """Set this effect's parameters from a preset"""
    bl_idname = "hydrobake.apply_preset"
    bl_label = "Apply Preset"
    bl_options = {"REGISTER", "UNDO"}

    preset: bpy.props.StringProperty(name="Preset")

    def execute(self, context):
        obj = _target(context, self)
        if obj is None:
            return {"CANCELLED"}
        beffect = effects.get(self.effect)
        values = beffect.presets.get(self.preset)
        if values is None:
            self.report({"ERROR"}, f"preset = {self.preset!r}: not a preset of {self.effect} ("
                                   f"{', '.join(sorted(beffect.presets)) or 'it has none'})")
            return {"CANCELLED"}
        settings = jobs.settings_of(obj, self.effect)
        if jobs.foreign(obj):
            self.report({"ERROR"}, jobs.foreign(obj))
            return {"CANCELLED"}
        if settings.is_baked:
            self.report({"ERROR"}, "Free the bake before changing its settings")
            return {"CANCELLED"}
        groups = beffect.core_class().groups()
        properties.from_params(groups, settings, {
            g: dict(spec.defaults(), **values.get(g, {})) for g, spec in groups.items()})
        for name, value in values.items():  # the effect's own settings a preset names
            if name not in groups:
                setattr(settings, name, value)
        return {"FINISHED"}


class HYDROBAKE_OT_remove_deleted_bakes(bpy.types.Operator):
    """Take the bakes of objects deleted while baked out of the materials that still show
    them, as their Free Bake would have (their files stay)"""
    bl_idname = "hydrobake.remove_deleted_bakes"
    bl_label = "Remove Deleted Objects' Bakes"
    bl_options = {"REGISTER", "UNDO"}

    effect: bpy.props.StringProperty(
        name="Effect", description="Only this effect's, e.g. 'snow'; empty for every effect's")

    def execute(self, context):
        known = effects.load_all()
        if self.effect and self.effect not in known:
            self.report({"ERROR"}, f"effect = {self.effect!r}: must be one of "
                                   f"{', '.join(sorted(known))}, or empty for all")
            return {"CANCELLED"}
        removed = []
        for name, beffect in known.items():
            if self.effect in ("", name):
                try:
                    removed += [f"{name} of '{n}'" for n in sorted(beffect.forget_deleted())]
                except Exception as exc:
                    traceback.print_exc()
                    self.report({"ERROR"}, f"{name}: could not remove a deleted object's "
                                           f"bake ({type(exc).__name__}: {exc})")
                    return {"CANCELLED"}
        if not removed:
            self.report({"INFO"}, "No deleted object's bake is shown in this file")
            return {"CANCELLED"}
        self.report({"INFO"}, f"Removed the {', '.join(removed)} (the files stay)")
        return {"FINISHED"}


def draw_cleanup_menu(self, context):
    """File > Clean Up, beside Purge Unused Data."""
    self.layout.operator(HYDROBAKE_OT_remove_deleted_bakes.bl_idname)


CLASSES = (HYDROBAKE_OT_bake, HYDROBAKE_OT_cancel_bake, HYDROBAKE_OT_free_bake,
           HYDROBAKE_OT_apply_preset, HYDROBAKE_OT_remove_deleted_bakes)
