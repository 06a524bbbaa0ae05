"""A bake of one object's effect, as the operators, the panels and the command line see it.

Scene data is read on the main thread when the job is made; the worker thread then touches
only the core (C and files); wiring the result back happens on the main thread again.
Jobs are keyed by object and effect *names*, never by Python references to Blender data."""
import contextlib
import inspect
import json
import os
import uuid
import warnings

import bpy

from ..core.bake import BakeRunner, BakeCache
from . import effects, paths, properties
from .bridge import animation
from .effects.base import BakeWarning, unoffered
from .reading_progress import ReadingProgress

ACTIVE = {}  # (object name, effect name) -> Job, while running or waiting to be finalized


def settings_of(obj, effect_name):
    return getattr(obj, f"hydrobake_{effect_name}")


def foreign(obj):
    """Why this file cannot keep a bake record on the object, or None. A linked object's
    settings are read from its library at every open, and so are a library override's (its
    Hydrobake settings are not overridable): a bake or free recorded here would be lost on
    the next save, and its material wiring left half in each file."""
    if obj.library is not None:
        return (f"{obj.name} is linked from {obj.library.filepath}, which keeps its bake "
                "record: bake or free it in that file, or make it local here (Object > "
                "Relations > Make Local)")
    if obj.override_library is not None:
        return (f"{obj.name} is a library override; its Hydrobake settings come from the "
                "library file at every open, so a bake recorded here would be lost: bake or "
                "free it in the library file, or make it local (Object > Relations > Make "
                "Local)")
    return None


def linked_parts(beffect, obj, settings):
    """Why the bake could not be wired in this file, or None: a mesh or material its wiring
    changes is linked from a library (an object made local alone keeps them so), and would
    come back from there, unwired, at the next open."""
    for o in beffect.wired_objects(obj, settings):
        parts = [(f"{o.name}'s mesh", o.data)] + [
            (f"{o.name}'s material '{slot.material.name}'", slot.material)
            for slot in o.material_slots if slot.material is not None]
        for what, block in parts:
            if block is not None and block.library is not None:
                return (f"{what} is linked from {block.library.filepath}, so the bake's "
                        "wiring could not be saved in it: make it local too (Object > "
                        "Relations > Make Local > Selected Objects, Data and Materials)")
    return None


def frame_range(scene, settings):
    if settings.use_scene_range:
        return scene.frame_start, scene.frame_end
    return settings.frame_start, settings.frame_end


@contextlib.contextmanager
def scene_context(context, scene):
    """Makes ``scene`` the context's scene (its first view layer, when it is not the context's
    own) while reading scene data, so evaluated data comes from its own depsgraph (a batch
    bake of a scene other than the window's), and evaluates it.

    Evaluation writes back to the data a bake reads (wiper angles, an Empty's place) only
    through an active depsgraph, and Blender makes one active only when asked for it, as a
    view layer's update() does. A scene that is not the window's, or one made the window's by
    ``blender -b --scene``, has none until then; a graph built earlier by a script's
    frame_set was not made active either, and left such data as the file had it (identity
    matrices, rest angles). The objects whose world matrix differs from the evaluated one are
    evaluated again; only those: a transform tagged on every object marked a cloth's cache
    outdated, and the next frame cut it short."""
    own = scene == context.scene
    layer = context.view_layer if own else scene.view_layers[0]
    with contextlib.nullcontext() if own else context.temp_override(scene=scene,
                                                                    view_layer=layer):
        layer.update()
        graph = layer.depsgraph
        stale = [o for o in scene.objects
                 if o.matrix_world != o.evaluated_get(graph).matrix_world]
        for o in stale:
            o.update_tag(refresh={"OBJECT"})
        if stale:
            layer.update()
        yield


def _same_folder(a, b):
    return bool(a) and bool(b) and os.path.realpath(a) == os.path.realpath(b)


def holders(folder, effect_name, but=None):
    """The objects whose settings record a bake of the effect in ``folder`` (but ``but``):
    Shift+D copies the record, so one bake can have several."""
    return [o for o in bpy.data.objects if o != but and settings_of(o, effect_name).is_baked
            and _same_folder(settings_of(o, effect_name).bake_folder, folder)]


HOLDER = "holder_id"  # in a bake's settings: the object it was recorded on, this session
BAKING = "baking_job"  # in a bake's settings while it runs: its job's token (see Job.target)


def _identity(obj):
    """The object's identity for this session (its address): a Shift+D copy has its own,
    though it copies every property. Blender 3.4 has no persistent one; undo may change it,
    and then the names decide."""
    return str(obj.as_pointer())


def wiring_owner(obj, effect_name):
    """The object whose bake's wiring (named after the name it was baked under) the record
    in ``obj``'s settings describes: the holder the bake was recorded on (known this session
    by its identity), else the holder still called by that name, or None when none is
    (renamed since; or a copy's original was)."""
    s = settings_of(obj, effect_name)
    name = s.get("baked_as") or obj.name
    group = holders(s.bake_folder, effect_name) if s.is_baked else []
    recorded_on = [h for h in group if settings_of(h, effect_name).get(HOLDER) == _identity(h)]
    if len(recorded_on) == 1:
        return recorded_on[0]
    if obj.name == name:
        return obj
    other = bpy.data.objects.get(name)
    if other is not None and other in holders(s.bake_folder, effect_name):
        return other
    return None


def copied_from(obj, effect_name):
    """The other object whose bake record ``obj`` holds as a copy (Shift+D copies the
    settings, the bake's folder and the name it was wired under), or None: others record the
    same bake and ``obj`` is not the one its wiring is named after. A copy owns neither the
    files nor the wiring."""
    s = settings_of(obj, effect_name)
    if not s.is_baked:
        return None
    others = holders(s.bake_folder, effect_name, but=obj)
    owner = wiring_owner(obj, effect_name) if others else obj
    if owner == obj:
        return None
    return owner if owner is not None else others[0]


def owns_record(obj, effect_name):
    """Whether ``obj`` records a bake of the effect of its own, not a Shift+D copy's of
    another object's."""
    return settings_of(obj, effect_name).is_baked and copied_from(obj, effect_name) is None


def forget(obj, effect_name):
    """Clears a bake record from the object's settings (not the files, not the wiring)."""
    s = settings_of(obj, effect_name)
    s.is_baked = False
    s.bake_folder = ""
    s.pop("baked_as", None)
    s.pop(HOLDER, None)


def refresh_holders():
    """After a file is opened, addresses are new: a bake recorded by one object only, or by
    several of which one still has the name it was baked under, is known to be that one's
    again (load_post)."""
    for effect_name in effects.load_all():
        groups = {}
        for o in bpy.data.objects:
            s = settings_of(o, effect_name)
            if s.is_baked and s.bake_folder:
                groups.setdefault(os.path.realpath(s.bake_folder), []).append(o)
        for group in groups.values():
            named = [o for o in group if settings_of(o, effect_name).get("baked_as") == o.name]
            owner = group if len(group) == 1 else named
            if len(owner) == 1:
                settings_of(owner[0], effect_name)[HOLDER] = _identity(owner[0])


def name_holder(obj, effect_name, folder):
    """Another object whose bake record would be taken by ``obj``'s bake into ``folder``:
    it records a bake in that folder, or one whose files and wiring go by the name ``obj``
    has now (it was renamed since, or copied from one that was), or None."""
    own = settings_of(obj, effect_name)
    # Not when ``obj`` itself is a Shift+D copy: renamed to the name the bake was made under,
    # it would bake over the original's files and into its material.
    owns = owns_record(obj, effect_name)
    for other in bpy.data.objects:
        if other == obj:
            continue
        s = settings_of(other, effect_name)
        if not s.is_baked:
            continue
        if owns and _same_folder(s.bake_folder, own.bake_folder):
            continue  # a copy of this object's own record: a re-bake replaces that bake
        if _same_folder(s.bake_folder, folder) or s.get("baked_as") == obj.name:
            return other
    return None


READING = set()  # Readings under way (a UI bake reads from a timer): cancel_all stops them


class Reading:
    """A Job being made: step() runs its reading of the scene to the next frame taken (None
    once the Job is made), showing progress (the cursor, unless another bake's shows) and
    keeping the prepare's BakeWarnings in job.warnings; close() stops it, the scene set back
    on its frame. Warnings are caught a step at a time: between steps the event loop runs,
    and other code's warnings are not the bake's."""

    def __init__(self, job, label, steps):
        self.job, self.steps, self.label = job, steps, label  # label: "Object/effect"
        job.warnings = []
        self.progress = ReadingProgress(label, busy=bool(ACTIVE))
        self.last = None  # the step taken last: (frame, done, total)
        self.closed = False
        self.ui_end = None  # a UI bake's: lets its timer and status text go at close
        READING.add(self)

    def step(self):
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", BakeWarning)
            try:
                self.last = next(self.steps)
            except StopIteration:
                self.last = None
            finally:
                keep = list(caught)
        self.job.warnings += [str(w.message) for w in keep
                              if issubclass(w.category, BakeWarning)]
        for w in keep:  # the others as they would have gone without the catch
            if not issubclass(w.category, BakeWarning):
                warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
        if self.last is not None:
            self.progress(*self.last)
        return self.last

    def close(self):
        if self.closed:
            return
        self.closed = True
        READING.discard(self)
        try:
            self.steps.close()  # (the scene back on its frame)
        finally:
            self.progress.close()
            if self.ui_end is not None:
                self.ui_end()


class Job:
    def __init__(self, context, obj, effect_name, frames=None, folder_override=None,
                 threads=None, scene=None, resume=False):
        """Reads the scene and makes the bake's runner at once (background mode, scripts,
        the command line). Job.stepwise reads the scene's frames one at a time."""
        reading = self._reading(context, obj, effect_name, frames, folder_override, threads,
                                scene, resume)
        with contextlib.closing(reading):
            while reading.step() is not None:
                pass

    @classmethod
    def stepwise(cls, context, obj, effect_name, resume=False):
        """A Reading that makes the Job as it is stepped, a frame of the scene's animation at
        a time (a UI bake steps it from a timer, so Esc can stop it between frames)."""
        return cls.__new__(cls)._reading(context, obj, effect_name, resume=resume)

    def _reading(self, context, obj, effect_name, *args, **kwargs):
        return Reading(self, f"{obj.name}/{effect_name}",
                       self._read(context, obj, effect_name, *args, **kwargs))

    def _read(self, context, obj, effect_name, frames=None, folder_override=None,
              threads=None, scene=None, resume=False):
        """The checks, the scene read by the effect's prepare (a generator of its frames'
        steps) and the runner made: yields after each frame it reads."""
        scene = scene or context.scene
        if foreign(obj):
            raise ValueError(foreign(obj))
        if not obj.users_collection:  # deleted, and kept only by a pointer to itself
            raise ValueError(f"{obj.name}: in no collection (deleted?); the next save would "
                             "drop it and leave its bake behind: link it to a collection to "
                             "bake it")
        self.object_name, self.effect_name = obj.name, effect_name
        self.beffect = effects.get(effect_name)
        settings = settings_of(obj, effect_name)
        self.folder = paths.bake_folder(obj, effect_name, settings, folder_override)
        self.override = folder_override
        self.copy_of = copied_from(obj, effect_name)  # a record to drop, not a bake to unwire
        if resume and self.copy_of is not None:
            raise ValueError(f"{obj.name}: nothing of its own to resume (its {effect_name} bake "
                             f"record is a copy of {self.copy_of.name}'s); bake it anew")
        # A resume stays in its folder, but is wired under the name the object has now:
        # another object's bake made under that name is checked for too (monkey 1560: a
        # renamed pool resumed under its copy's baked name took the copy's made material).
        into = settings.bake_folder if (resume and settings.bake_folder and not folder_override) \
            else self.folder
        holder = name_holder(obj, effect_name, into)
        if holder is not None:  # its files and wiring would be taken for this object's
            raise ValueError(
                f"{obj.name}: {holder.name} records a {effect_name} bake made under this "
                f"name or in this folder ({into}) (it was renamed, or is a Shift+D "
                f"copy keeping the record); free or re-bake {holder.name} first, or "
                "rename this object")
        other = None if resume else made_elsewhere(self.folder)
        if other is not None:  # a bake would replace that file's
            raise ValueError(f"{self.folder} holds a {effect_name} bake that {other} made, "
                             "which may still show it: free it there, or set another Cache "
                             "Folder")
        gone = [] if resume or _same_folder(settings.bake_folder, self.folder) else [
            n for n in sorted(self.beffect.deleted_bakes())
            if paths.shown_from(self.folder, [f"HBK_{n}_"])]
        if gone:  # the bake would change what Undo brings back with the deleted object
            raise ValueError(f"{self.folder} holds the {effect_name} bake of deleted "
                             f"{', '.join(repr(n) for n in gone)}, which this file still shows "
                             "(Undo brings it back): take it out with File > Clean Up > "
                             f"Remove Deleted Objects' Bakes first, or rename {obj.name}")
        wrong = unoffered(settings) or linked_parts(self.beffect, obj, settings)
        if wrong:  # (unoffered: a script's setattr skips the panel's choice)
            raise ValueError(wrong)
        groups = self.beffect.core_class().groups()
        params = properties.to_params(groups, settings)
        for g, spec in groups.items():
            if "threads" in spec.by_name:
                params[g]["threads"] = scene.hydrobake.threads if threads is None else threads
        start, end = frames or frame_range(scene, settings)
        # Shapes (a ground, a glass, the faces of a snowy mesh) are read at the bake's first
        # frame as the animation gives it, not at whatever frame the scene is on (nor with an
        # animated value changed there and not keyed, which the frames after it would not
        # have): the same bake whichever frame Bake is pressed on, and a resume reads what the
        # bake it continues read.
        self.start = start
        with scene_context(context, scene), animation.at_frame(scene, start, always=True):
            got = self.beffect.prepare(context, obj, settings, params, (start, end))
            params, inputs = (yield from got) if inspect.isgenerator(got) else got
        self.scene_name = scene.name
        effect = self.beffect.core_class()(params, inputs)
        if not resume:  # (a resume's is the bake's it continues, said then)
            for text in effect.forecast(start, end):
                warnings.warn(f"{obj.name}: {text}", BakeWarning)
        self.recorded = paths.stored(self.folder, settings, folder_override)  # in the file
        if resume and settings.bake_folder and not folder_override:
            self.folder = settings.bake_folder  # continue where the bake actually is,
            # recorded as it was: the Cache Folder may have changed to or from an absolute
            # one since, and a relative record made absolute is lost when the project moves
            raw = settings.get("bake_folder", "")
            self.recorded = raw if raw.startswith("//") else self.folder
        self.runner = BakeRunner(effect, self.folder, start, end, resume=resume, header={
            "object": obj.name, "blend": bpy.data.filepath, "folder": self.folder,
            "file_tag": paths.file_tag(self.folder)})
        # The object is marked, so that the bake finds it again if it is renamed meanwhile
        # (and never takes another object given its old name).
        self.token, self.pointer = uuid.uuid4().hex, obj.as_pointer()
        self.ui_end = None  # a modal bake's: lets its progress go when cancel_all stops it
        settings[BAKING] = self.token

    @property
    def key(self):
        return (self.object_name, self.effect_name)

    def _beside(self, folder):
        """Whether ``folder`` is another object name's folder of this bake's cache (not an
        --output or another Cache Folder's)."""
        return self.override is None and _same_folder(
            os.path.dirname(os.path.abspath(bpy.path.abspath(folder))),
            os.path.dirname(self.folder))

    def target(self):
        """The object being baked: the one its token marks (renamed since, maybe; of a
        Shift+D copy and its original, the original), else the one still called by its name
        and marked by no other bake (an undo dropped the mark), or None (deleted)."""
        obj = bpy.data.objects.get(self.object_name)
        if obj is not None and settings_of(obj, self.effect_name).get(BAKING) == self.token:
            return obj
        marked = [o for o in bpy.data.objects
                  if settings_of(o, self.effect_name).get(BAKING) == self.token]
        if marked:
            return next((o for o in marked if o.as_pointer() == self.pointer), marked[0])
        if obj is not None and not any(j is not self and j.effect_name == self.effect_name and
                                       j.token == settings_of(obj, self.effect_name).get(BAKING)
                                       for j in ACTIVE.values()):
            return obj
        return None

    def finalize(self, context):
        """Main thread, after the runner stopped: record the bake and wire what exists."""
        ACTIVE.pop(self.key, None)
        self.runner.effect.close()
        obj = self.target()
        for o in bpy.data.objects:  # the mark, on the object and on copies made meanwhile
            s = settings_of(o, self.effect_name)
            if s.get(BAKING) == self.token:
                del s[BAKING]
        if obj is None:  # deleted while baking: the files stay, nothing to wire
            return
        if self.runner.state.status == "FAILED" and self.runner.state.frame is None:
            return  # refused before a frame (a resume that does not match): all as it was
        settings = settings_of(obj, self.effect_name)
        manifest = BakeCache(self.folder).read_manifest()
        if manifest and manifest["frames"]:
            old_name, old_folder = settings.get("baked_as", obj.name), settings.bake_folder
            if self.copy_of is not None:  # the record was a copy of another object's bake:
                # nothing of ours, and its name is the original's, whose wiring (a fluid's
                # surface and Volume) this bake took for its own (monkey --more 4001)
                settings.pop("baked_as", None)
            else:
                if old_name != obj.name:  # renamed: unwire the old
                    self.beffect.remove(context, obj, settings)
                if settings.is_baked and old_folder and \
                        not _same_folder(old_folder, self.folder) and \
                        (old_name != obj.name or self._beside(old_folder)):
                    # Re-baked under a new name (now or at a resume since, which kept the
                    # old folder), the old bake is replaced as in place: freed once this one
                    # is complete (resumed, if cancelled) and the file saved. A bake sent
                    # elsewhere (--output, another Cache Folder) replaces nothing.
                    supersede(settings, old_folder, _made_for(old_folder, old_name))
            # Relative to where the file is now: it may have been saved elsewhere meanwhile.
            recorded = bpy.path.relpath(self.folder) if self.recorded.startswith("//") and \
                bpy.data.filepath else self.recorded
            settings.is_baked = True
            settings.bake_folder = recorded
            superseded_no_more(self.folder, self.effect_name)
            scene = bpy.data.scenes.get(self.scene_name) or context.scene
            try:
                with scene_context(context, scene), animation.at_frame(scene, self.start):
                    # (wiring measured on the shapes the bake read: a BOX atlas, a pool's grid)
                    self.beffect.apply(context, obj, settings, self.folder, manifest)
            finally:  # recorded as wired, even in part: Free Bake then undoes what was done
                settings["baked_as"] = obj.name
                settings[HOLDER] = _identity(obj)
                paths.relink(self.folder, recorded)


def running(obj, effect_name):
    """The job baking the object's effect (it may have been renamed since it began), or
    None."""
    return next((j for j in list(ACTIVE.values())
                 if j.effect_name == effect_name and j.target() == obj), None)


def unrecorded_bake(obj, effect_name):
    """The folder of a bake of the object's effect in its folder that the object does not
    record (Blender quit, another file was opened or the addon was disabled while it ran; an
    undo dropped the record), which Resume can continue or record; else None."""
    settings = settings_of(obj, effect_name)
    if settings.is_baked:
        return None
    try:
        folder = paths.bake_folder(obj, effect_name, settings)
        m = BakeCache(folder).read_manifest()
    except (paths.CacheFolderError, ValueError, OSError):
        return None
    if not m or not m.get("frames") or m.get("object") != obj.name or \
            m.get("effect") != effect_name or holders(folder, effect_name):
        return None
    return folder



# In a bake's settings: the bakes it replaced, JSON [[folder, name], ...] (a string: folders
# are too long for ID property keys). Older records held one [folder, name] pair.
SUPERSEDED = "superseded"


def _superseded(settings):
    value = settings.get(SUPERSEDED)
    if value is None:
        return []
    if isinstance(value, str):
        return [tuple(p) for p in json.loads(value)]
    return [(str(value[0]), str(value[1]))]


def _made_for(folder, name):
    """The object name the bake in ``folder`` was made for (its manifest's), else ``name``."""
    try:
        m = BakeCache(bpy.path.abspath(folder)).read_manifest()
    except ValueError:
        m = None
    return str(m.get("object", name)) if m else name


def supersede(settings, folder, name):
    """Records that the bake in ``folder`` (made for the object called ``name``) is replaced;
    free_superseded frees it once the bake that replaced it is complete and the file saved."""
    pending = _superseded(settings)
    if not any(_same_folder(f, folder) for f, _ in pending):
        pending.append((folder, name))
    settings[SUPERSEDED] = json.dumps(pending)


def superseded_no_more(folder, effect_name):
    """A bake just recorded in ``folder`` is not the one another object's re-bake replaced
    there: no object's record may free it as replaced any more (a copy re-baked elsewhere,
    then its original baked there again and was deleted while baked: the save freed the
    deleted object's files, which Undo brings back; monkey --relations 27)."""
    where = bpy.path.abspath(folder)
    for obj in bpy.data.objects:
        settings = settings_of(obj, effect_name)
        pending = _superseded(settings)
        kept = [(f, n) for f, n in pending if not _same_folder(bpy.path.abspath(f), where)]
        if len(kept) < len(pending):
            if kept:
                settings[SUPERSEDED] = json.dumps(kept)
            else:
                del settings[SUPERSEDED]


def free_superseded():
    """After the .blend is saved (save_post): frees the bakes that renamed objects' complete
    re-bakes replaced, as a re-bake in place would have replaced them; else they stay on disk,
    and an object later given the old name finds them there. Not before the save: the file
    on disk still records the old bake until then (quit without saving, and it is intact).
    Only a bake made for that name and effect, and that no object records now."""
    for effect_name in effects.load_all():
        for obj in bpy.data.objects:
            settings = settings_of(obj, effect_name)
            if SUPERSEDED not in settings:
                continue
            if not settings.is_baked:
                del settings[SUPERSEDED]  # a Shift+D copy's, freed since (free frees its own)
                continue
            if bake_state(obj, effect_name) != "COMPLETE":
                continue  # a cancelled re-bake replaces nothing yet: kept until it completes
            _free_replaced(settings, effect_name)


def _free_replaced(settings, effect_name):
    """Frees the bakes ``settings`` records as replaced (see supersede) and forgets them: each
    only if made for that name and effect, by this file, and recorded by no object now.
    Returns the files removed."""
    pending = _superseded(settings)
    settings.pop(SUPERSEDED, None)
    removed = []
    for folder, name in pending:
        if _same_folder(folder, settings.bake_folder) or holders(folder, effect_name):
            continue
        cache = BakeCache(folder)
        try:
            old = cache.read_manifest()
        except ValueError:
            continue
        if old and old.get("object") == name and old.get("effect") == effect_name and \
                _made_here(old, folder):
            removed += cache.free()
    return removed


def _made_here(manifest, folder):
    """Whether this file may take the bake in ``folder`` for its own: made by this .blend, by
    one no longer where it was (moved with its project), or somewhere else than ``folder``
    (a copy of the project: these files are the copy's). A bake another .blend on disk made in
    this very folder is that file's too (this one saved from it as a new version, or both
    baking into one absolute Cache Folder), and may be all it has: a versioned save, renamed
    and re-baked, had freed the first version's bake."""
    blend = manifest.get("blend")
    if not blend or not bpy.data.filepath or not os.path.exists(blend) or \
            _same_folder(blend, bpy.data.filepath):
        return True
    made_in = manifest.get("folder")
    if made_in is None:  # (a manifest from before it was recorded): where a relative
        # Cache Folder puts it
        return not os.path.realpath(folder).startswith(
            os.path.join(os.path.realpath(os.path.dirname(blend)), ""))
    return not _same_folder(made_in, folder)


def made_elsewhere(folder):
    """The other .blend whose bake ``folder`` holds (see _made_here), or None."""
    try:
        m = BakeCache(folder).read_manifest()
    except ValueError:
        return None
    return m["blend"] if m is not None and not _made_here(m, folder) else None


def bake_state(obj, effect_name):
    """'NONE', 'PARTIAL' (cancelled, killed or damaged: can be resumed) or 'COMPLETE'."""
    settings = settings_of(obj, effect_name)
    if not settings.bake_folder:
        return "NONE"
    try:
        m = BakeCache(settings.bake_folder).read_manifest()
    except ValueError:
        return "PARTIAL"
    if not m or not m["frames"]:
        return "NONE"
    return "COMPLETE" if m.get("complete") else "PARTIAL"


def folder_of(obj, effect_name):
    """The folder of the object's bake: the recorded one, else where a bake would go."""
    settings = settings_of(obj, effect_name)
    return settings.bake_folder or paths.bake_folder(obj, effect_name, settings)


def kept_after_free(folder):
    """What a free left in ``folder``, as a message: a bake whose manifest cannot be read
    (edited by hand, not ours: a free removes only what a manifest names), or that another
    .blend made (see free); None if there is none."""
    try:
        m = BakeCache(folder).read_manifest()
    except ValueError as exc:
        return f"{exc}: its files are kept (delete the folder by hand)"
    if m is not None and not _made_here(m, folder):
        return (f"{m['blend']} made this bake and may still show it: its files in {folder} "
                "are kept (free it there, or delete the folder by hand)")
    return None


def free(context, obj, effect_name):
    """Removes the bake's files (and nothing else) and unwires it."""
    if foreign(obj):  # its record, wiring and files are the library's
        raise ValueError(foreign(obj))
    settings = settings_of(obj, effect_name)
    beffect = effects.get(effect_name)
    folder = folder_of(obj, effect_name)
    others = holders(folder, effect_name, but=obj)
    if others:  # others record this bake too (Shift+D copies): its files stay for them
        if settings.is_baked:
            if wiring_owner(obj, effect_name) == obj:
                beffect.remove(context, obj, settings)  # the wiring named after this object
            else:  # a copy: what the bake changed on it alone
                keep = {s.material for o in others for s in o.material_slots if s.material}
                beffect.let_go(context, obj, settings, keep)
            forget(obj, effect_name)
        return []
    cache = BakeCache(folder)
    if not settings.is_baked:
        # No record: nothing of this object's is wired (a bake is wired when recorded), and
        # its slots may be a baked object's (a freed Shift+D copy). Only files a bake of this
        # object left unrecorded (Blender died before it finished) are removed; not those of
        # an object of that name deleted while baked, which the file still shows and undo
        # brings back (monkey --more --delete-baked 1673).
        try:
            m = cache.read_manifest()
        except ValueError:
            m = None
        if m is None or m.get("object") != obj.name or paths.shown_from(folder) or \
                not _made_here(m, folder):
            return []
        return cache.free()
    # Made by another .blend still on disk (this one saved from it as a new version): that
    # one may still show it, so this file lets go of it and its files stay (kept_after_free).
    theirs = made_elsewhere(folder) is not None  # (unreadable: cache.free keeps it anyway)
    # Unwired before the files go: if unwiring fails, the bake and its record stay as they
    # were (the files had been deleted under a record that still named them). Under the
    # folder's lock, so that no other process bakes into it meanwhile.
    with cache.locked():
        beffect.remove(context, obj, settings)
        forget(obj, effect_name)
        removed = [] if theirs else cache.free()
    with contextlib.suppress(OSError):
        os.rmdir(cache.folder)  # only if empty: never remove what is not ours
    # The bakes this one replaced under an older name, kept for the saved file until the next
    # save: freed with it, as they would have been with a re-bake in place (left, nothing
    # would free them once the object is deleted).
    return removed + _free_replaced(settings, effect_name)


def cancel_all(timeout=5.0):
    """Cancels every running bake and waits for the threads (their frames stay valid); stops
    the bakes still reading the scene."""
    for reading in list(READING):
        reading.close()
    for job in list(ACTIVE.values()):
        job.runner.cancel()
        if job.runner.join(timeout):  # never free a handle a live thread still uses
            job.runner.effect.close()
        if job.ui_end is not None:
            job.ui_end()
        for o in bpy.data.objects:  # unrecorded: the panel offers to resume it (ui)
            s = settings_of(o, job.effect_name)
            if s.get(BAKING) == job.token:
                del s[BAKING]
    ACTIVE.clear()
