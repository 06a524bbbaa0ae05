"""Batch command line, run inside Blender in background mode:

    blender -b shot.blend --python-exit-code 1 \
        --python-expr "import hydrobake.blender.cli as c; c.main()" -- bake --frames 1-48

(``build/hydrobake-batch shot.blend bake --frames 1-48`` says the same.)

Commands:
    list                          effects and objects in the file, and their bake state
    bake  [--objects A,B] [--effects caustics,...] [--frames S-E] [--output DIR] [--threads N]
          [--overrides FILE.json] [--no-save]
    resume  (the same options) continue interrupted bakes from their last good checkpoint
    free  [--objects A,B] [--effects ...]
    regress --golden DIR [--existing DIR] [--report DIR] [--tolerances FILE.json]
          (and the bake options): bake (or take an existing bake) and compare it with a golden
          bake; exit 1 on a regression (see hydrobake.core.regress)
--overrides sets parameters for this run only, e.g.
    {"Water/caustics": {"map_resolution": 128, "water": {"width": 48}}, "*/snow": {...}}
Without --objects/--effects, every object with an enabled effect is used. Progress goes to
stdout a line per frame; errors go to stderr. Exit codes: 0 done, 2 a usage error (argparse:
an unknown option, a bad --frames, an empty --objects), 1 anything else (an unknown object or
effect, a bad override, a failed bake), 130 / 143 a bake stopped by SIGINT / SIGTERM.
"""
import argparse
import ctypes
import json
import os
import signal
import sys
import threading
import time

import bpy

from ..core import errors, jsonfile
from . import effects, jobs, paths
from .effects.base import poll_of


def _argv():
    argv = sys.argv
    return argv[argv.index("--") + 1:] if "--" in argv else []


MAX_FRAME = 1048574  # Blender's MAXFRAME: no scene or frame property goes past it


def _frames(text):
    try:
        a, dash, b = text.partition("-")
        start, end = int(a), int(b) if dash else int(a)  # "5" is one frame; "5-" is a typo
    except ValueError:
        raise argparse.ArgumentTypeError(f"--frames {text!r}: must be START-END, e.g. 1-48")
    if start < 0 or end < start or end > MAX_FRAME:
        # Past Blender's last frame the bake would run on for ever (1-99999999999 did).
        raise argparse.ArgumentTypeError(f"--frames {text!r}: need 0 <= START <= END <= "
                                         f"{MAX_FRAME} (Blender's last frame)")
    return start, end


def _names(option):
    """A comma-separated list of names for ``option``; an empty one is refused (leaving the
    option out means "every enabled one", an empty value must not say the same)."""
    def parse(text):
        names = [t for t in text.split(",") if t.strip()]
        if not names:
            raise argparse.ArgumentTypeError(
                f"{option} {text!r}: empty; name at least one, or leave {option} out for "
                "every enabled one")
        return names
    return parse


def _folder(text):
    """--output: made absolute here, so the file records the folder itself, not one relative
    to wherever this run happened to start ('//' stays relative to the .blend)."""
    if not text.strip():
        raise argparse.ArgumentTypeError(f"--output {text!r}: empty; give a folder, or leave "
                                         "--output out for each effect's Cache Folder")
    return text if text.startswith("//") else os.path.abspath(text)


def _threads(text):
    """--threads: 0 (every core) to 1024."""
    try:
        n = int(text)
    except ValueError:
        n = None
    if n is None or not 0 <= n <= 1024:
        raise argparse.ArgumentTypeError(f"--threads {text!r}: must be an integer in [0, 1024] "
                                         "(0 = every core)")
    return n


def _save():
    """Saves the .blend (the bake's record and wiring); a file that cannot be written is
    reported, not a traceback: the bake itself is on disk."""
    try:
        bpy.ops.wm.save_mainfile()
    except RuntimeError as exc:
        print(f"hydrobake: error: could not save {bpy.data.filepath}: "
              f"{str(exc).strip().splitlines()[-1]} (pass --no-save to leave it as it is)",
              file=sys.stderr, flush=True)
        return False
    return True


def parser():
    p = argparse.ArgumentParser(prog="hydrobake", description="Hydrobake batch baking")
    sub = p.add_subparsers(dest="command", required=True)
    sub.add_parser("list", help="show effects, objects and bake state")
    for name in ("bake", "resume", "free", "regress"):
        s = sub.add_parser(name, help=f"{name} bakes")
        s.add_argument("--objects", type=_names("--objects"),
                       help="comma-separated object names")
        s.add_argument("--effects", type=_names("--effects"),
                       help="comma-separated effect names")
        if name != "free":
            s.add_argument("--frames", type=_frames, help="frame range START-END")
            s.add_argument("--output", type=_folder,
                           help="cache folder override (a relative one is taken from the "
                                "current folder)")
            s.add_argument("--threads", type=_threads, default=None,
                           help="threads (0 = all cores); results do not depend on it")
            s.add_argument("--overrides", help="JSON file of parameters for this run only")
            s.add_argument("--no-save", action="store_true",
                           help="do not save the .blend after baking")
        if name == "regress":
            s.add_argument("--golden", required=True, help="folder of the golden bake")
            s.add_argument("--existing", help="compare this bake folder instead of baking")
            s.add_argument("--report", help="folder for report.json and report.html")
            s.add_argument("--tolerances", help="JSON file of tolerances per effect/stream")
    return p


def _object_names(pieces):
    """The object names in --objects' comma-separated pieces: at each piece, the longest run
    of pieces that, joined by commas again, names an object of the file (a name may hold a
    comma: "Wall, North"); else the piece alone."""
    out, i = [], 0
    while i < len(pieces):
        j = next((j for j in range(len(pieces), i + 1, -1)
                  if ",".join(pieces[i:j]) in bpy.data.objects), i + 1)
        out.append(",".join(pieces[i:j]))
        i = j
    return out


def targets(objects=None, effect_names=None):
    """(object, effect name) pairs: named ones, else every enabled effect."""
    known = effects.load_all()
    objects = _object_names(objects) if objects else objects
    for name in effect_names or ():
        if name not in known:
            raise KeyError(f"--effects {name}: not an effect; known: {', '.join(sorted(known))}")
    out = []
    for obj_name in objects or [o.name for o in bpy.data.objects]:
        obj = bpy.data.objects.get(obj_name)
        if obj is None:
            raise KeyError(f"--objects {obj_name}: no such object in {bpy.data.filepath}")
        for name, beffect in known.items():
            if effect_names and name not in effect_names:
                continue
            settings = getattr(obj, f"hydrobake_{name}", None)
            if settings is None or not beffect.poll(obj) or \
                    (not objects and not obj.users_collection):  # (deleted: Job refuses it)
                continue
            if not objects and settings.enabled and jobs.foreign(obj):  # its library's
                print(f"hydrobake: {obj.name}/{name} skipped: {jobs.foreign(obj)}",
                      file=sys.stderr, flush=True)
                continue
            if settings.enabled or (objects and effect_names):
                out.append((obj, name))
    return out


def _print_frame(job, t0):
    def on_frame(state):
        eta = state.eta()
        print(f"hydrobake: {job.object_name}/{job.effect_name} frame {state.written} "
              f"({state.done}/{state.total}) elapsed {time.monotonic() - t0:.1f}s"
              + (f" remaining {eta:.1f}s" if eta is not None else ""), flush=True)
    return on_frame


def _load_overrides(path):
    """The --overrides table: a JSON object of objects, read with the file's name in every
    error."""
    table = jsonfile.read(path, "--overrides")
    if not isinstance(table, dict) or not all(isinstance(v, dict) for v in table.values()):
        raise ValueError(f"--overrides {path}: must be a JSON object of objects "
                         '{"Object/effect": {"setting": value, ...}, ...}')
    return table


def _check_keys(table, path, pairs):
    """Every key is "Object/effect" for an object of this file that can have the effect, or
    "*/effect" (every object baked with it); anything else is refused with the valid keys."""
    known = effects.load_all()

    def can_have(obj, name):
        return hasattr(obj, f"hydrobake_{name}") and known[name].poll(obj)

    for key in table:
        obj_name, slash, name = key.rpartition("/")  # object names may hold '/', effects not
        if not slash:
            why = 'must be "Object/effect" or "*/effect"'
        elif name not in known:
            why = f"{name!r} is not an effect (effects: {', '.join(sorted(known))})"
        elif obj_name == "*":
            continue
        elif obj_name not in bpy.data.objects:
            why = f"no object {obj_name!r} in {bpy.data.filepath or 'the file'}"
        elif not can_have(bpy.data.objects[obj_name], name):
            why = f"{obj_name} cannot have the {name} effect"
        else:
            continue
        valid = sorted({f"{o.name}/{e}" for o in bpy.data.objects for e in known
                        if can_have(o, e) and (getattr(o, f"hydrobake_{e}").enabled or
                                               (o, e) in pairs)})
        valid += [f"*/{e}" for e in sorted(known)]
        shown = ", ".join(valid[:40]) + (f", ... ({len(valid) - 40} more)"
                                         if len(valid) > 40 else "")
        raise KeyError(f"--overrides {path}: key {key!r}: {why}; valid keys: {shown}")


def _float32(v):
    """v as the float32 a Blender float property holds (its limits are float32 too)."""
    try:
        return ctypes.c_float(v).value
    except OverflowError:  # an int past any float
        return float("inf") if v > 0 else float("-inf")


def _check_value(target, attr, value, where):
    """Refuses what Blender's setattr would take silently: a number outside the property's
    hard range (it clamps: a map resolution of 0 bakes 16), and true/false for a number
    (True is 1 to it). Other wrong types are left to Blender, whose error is clear."""
    prop = target.bl_rna.properties[attr]
    if prop.type not in {"INT", "FLOAT"}:
        return
    values = value if isinstance(value, (list, tuple)) else [value]
    lo, hi = prop.hard_min, prop.hard_max
    span = f"[{lo:g}, {hi:g}]" if prop.type == "FLOAT" else f"[{lo}, {hi}]"
    kind = "an integer" if prop.type == "INT" else "a number"
    for v in values:
        if isinstance(v, bool):
            raise ValueError(f"--overrides {where} = {json.dumps(value)}: must be {kind} in "
                             f"{span}, not true/false")
        if not isinstance(v, (int, float)):
            continue  # Blender names the type it expects
        x = _float32(v) if prop.type == "FLOAT" else v
        if not lo <= x <= hi:  # NaN too
            raise ValueError(f"--overrides {where} = {json.dumps(value)}: must be in {span}")


# What a bake records about itself, not parameters: an override of these would be put back
# over the new bake's own record when the run ends (a bake without its folder, or on disk but
# not marked baked). Targets are chosen by --objects and --effects, not by "enabled".
_NOT_PARAMETERS = {
    "is_baked": "it is the bake's record, set by the bake",
    "bake_folder": "it is the bake's record (use --output for where bakes go)",
    "name": "it is not a parameter",
    "enabled": "choose what is baked with --objects and --effects",
}
_ID_TYPES = {"Object": "objects", "Image": "images", "Collection": "collections",
             "NodeTree": "node_groups", "Material": "materials"}


def _pointer_value(target, attr, value, where):
    """A data-block setting (Ground, Car, Obstacles ...) given by name: the data-block of
    that name, checked with the setting's own poll (Python's setattr skips it: a camera
    would go in as a pool's ground). null clears it; other values are Blender's to refuse."""
    if not isinstance(value, str):
        return value
    prop = target.bl_rna.properties[attr]
    kind = prop.fixed_type.identifier
    blocks = getattr(bpy.data, _ID_TYPES.get(kind, ""), None)
    if blocks is None:
        return value
    block = blocks.get(value)
    if block is None:
        raise ValueError(f"--overrides {where} = {json.dumps(value)}: no {kind} of that name in "
                         f"{bpy.data.filepath or 'the file'}")
    poll = poll_of(target, attr)
    if poll is not None and not poll(target, block):
        takes = getattr(poll, "takes", "what the panel offers")
        raise ValueError(f"--overrides {where} = {json.dumps(value)}: {value} cannot be the "
                         f"{prop.name}, which takes {takes}")
    return block


def apply_overrides(pairs, path):
    """Sets parameters from a JSON file {"Object/effect" or "*/effect": {...}} (in memory);
    returns what they were, [(target, name, value)] in the order set (restore_overrides).
    Keys, shapes, types and ranges are checked first; on an error (KeyError, ValueError
    naming the key) what was set is put back."""
    undo = []
    if not path:
        return undo
    table = _load_overrides(path)
    _check_keys(table, path, pairs)

    def put(target, attr, value, where):
        _check_value(target, attr, value, where)
        if target.bl_rna.properties[attr].type == "POINTER":
            value = _pointer_value(target, attr, value, where)
        was = getattr(target, attr)  # an array is a live view: copied before it is set
        was = tuple(was) if hasattr(was, "__len__") and not isinstance(was, str) else was
        try:
            setattr(target, attr, value)
        except (TypeError, ValueError, AttributeError, OverflowError) as exc:  # Blender's
            raise ValueError(f"--overrides {where}: {exc}") from None
        undo.append((target, attr, was))

    def settle(target, values, key, prefix=""):
        for attr, value in values.items():
            name = f"{prefix}{attr}"
            prop = target.bl_rna.properties.get(attr)
            if prop is None or attr == "rna_type":
                raise KeyError(f"--overrides {key}: {name} is not a "
                               f"{'parameter' if prefix else 'setting'}")
            group = getattr(target, attr)
            if isinstance(group, bpy.types.PropertyGroup):  # a group of parameters
                if not isinstance(value, dict):
                    raise ValueError(
                        f"--overrides {key}: {name} is a group of settings: give an object "
                        f'{{"setting": value, ...}}, not {json.dumps(value)}')
                settle(group, value, key, f"{name}.")
            elif isinstance(value, dict):
                raise ValueError(f"--overrides {key}: {name} is a single setting, not a group: "
                                 "give its value, not an object")
            elif prop.type == "COLLECTION" or prop.is_readonly:
                raise ValueError(f"--overrides {key}: {name} cannot be set")
            elif not prefix and attr in _NOT_PARAMETERS:
                raise ValueError(f"--overrides {key}: {name} cannot be set: "
                                 f"{_NOT_PARAMETERS[attr]}")
            else:
                put(target, attr, value, f"{key}: {name}")
                named.append((key, name))

    try:
        for obj, name in pairs:
            named = []
            settings = jobs.settings_of(obj, name)
            for key in (f"*/{name}", f"{obj.name}/{name}"):  # the object's own entry wins
                if key in table:
                    settle(settings, table[key], key)
            derived = effects.get(name).derived(settings)
            for key, setting in named:
                if setting in derived:  # prepare would replace it without a word
                    raise ValueError(f"--overrides {key}: {setting} cannot be set for "
                                     f"{obj.name}: {derived[setting]}")
    except (KeyError, ValueError):
        restore_overrides(undo)
        raise
    return undo


def restore_overrides(undo):
    for target, attr, value in reversed(undo):
        setattr(target, attr, value)


class Interrupts:
    """While bakes run, the first SIGINT (Ctrl-C) or SIGTERM cancels the running bake through
    BakeRunner.cancel: its recorded frames stay valid and a later ``resume`` continues it; no
    further target starts. A second signal ends the process at once (what is on disk is still
    whole: files are renamed into place complete).

    Python runs a signal handler only in the main thread, between bytecodes: the bake runs in
    a worker thread (run_job) while the main thread waits in short joins, so the handler runs
    at once and its cancel reaches a long C call through the progress's cancel flag. Without
    this, Blender's own SIGINT handler only sets a break flag that nothing reads, and SIGTERM
    kills with no word."""

    SIGNALS = (signal.SIGINT, signal.SIGTERM)

    def __init__(self):
        self.signum = None
        self.runner = None
        self._old = {}

    def __enter__(self):
        if threading.current_thread() is threading.main_thread():
            for sig in self.SIGNALS:
                self._old[sig] = signal.signal(sig, self._handle)
        return self

    def __exit__(self, *exc):
        for sig, old in self._old.items():
            signal.signal(sig, signal.SIG_DFL if old is None else old)  # None: Blender's own

    def _handle(self, signum, frame):
        name = signal.Signals(signum).name
        if self.signum is not None:
            _say(f"hydrobake: {name} again: stopping at once")
            os._exit(self.code)
        self.signum = signum
        if self.runner is not None:
            self.runner.cancel()
        _say(f"hydrobake: {name}: cancelling (again to stop at once)")

    @property
    def code(self):
        """The conventional exit code of a process stopped by the signal: 128 + its number."""
        return 128 + self.signum if self.signum else 0

    def run_job(self, job):
        """Runs the job's bake in a worker thread (as the UI does) until it ends."""
        self.runner = job.runner
        try:
            if self.signum is None:  # a signal during setup: the folder stays as it was
                job.runner.start()
                while not job.runner.join(0.1):
                    pass
        finally:
            self.runner = None


def _say(line):
    """Writes a line to stderr from a signal handler: unbuffered, as the handler may have
    interrupted the main thread inside a print to the same stream."""
    os.write(2, (line + "\n").encode())


def bake(args, resume=False):
    with Interrupts() as stop:
        code = _bake(args, resume, stop)
    return stop.code or code


def _bake(args, resume, stop):
    failures = recorded = 0
    pairs = targets(args.objects, args.effects)
    undo = apply_overrides(pairs, getattr(args, "overrides", None))
    if not pairs:
        linked = " of this file (those of linked objects are baked in their libraries)" if \
            any(jobs.foreign(o) for o in bpy.data.objects) else ""
        raise KeyError(f"nothing to bake: no object{linked} has an enabled Hydrobake effect "
                       "(use --objects and --effects)")
    def not_started(rest):
        left = ", ".join(f"{o.name}/{n}" for o, n in rest)
        print(f"hydrobake: not started: {left}", file=sys.stderr, flush=True)

    for i, (obj, name) in enumerate(pairs):
        if stop.signum:
            not_started(pairs[i:])
            break
        t0 = time.monotonic()
        scene = obj.users_scene[0] if obj.users_scene else bpy.context.scene
        original = jobs.copied_from(obj, name) if resume else None
        if original is not None:  # a Shift+D copy's record
            print(f"hydrobake: {obj.name}/{name} skipped: its record is a copy of "
                  f"{original.name}'s bake; nothing of its own to resume", flush=True)
            continue
        try:  # a target that cannot be set up is reported; the others still bake
            job = jobs.Job(bpy.context, obj, name, frames=args.frames,
                           folder_override=args.output, threads=args.threads, scene=scene,
                           resume=resume)
        except Exception as exc:
            print(f"hydrobake: {obj.name}/{name} failed: {exc}", file=sys.stderr, flush=True)
            failures += 1
            continue
        for text in job.warnings:
            print(f"hydrobake: {obj.name}/{name} warning: {text}", file=sys.stderr, flush=True)
        job.runner.on_frame = _print_frame(job, t0)
        jobs.ACTIVE[job.key] = job
        try:
            stop.run_job(job)
        finally:
            job.finalize(bpy.context)
        s, error = job.runner.state, job.runner.error
        recorded += s.status != "PENDING"
        if s.status == "PENDING":  # never started: a signal came while it was set up
            not_started(pairs[i:])
            break
        if s.status == "CANCELLED" and stop.signum:
            after = (f"after frame {s.written}" if s.written >= s.frame_start
                     else "before its first frame")
            print(f"hydrobake: {obj.name}/{name}: cancelled {after}", file=sys.stderr,
                  flush=True)
            continue
        if error is not None:  # report every target, then fail
            print(f"hydrobake: {obj.name}/{name} failed: {error}", file=sys.stderr, flush=True)
            failures += 1
        if job.runner.resumed_from is not None:
            print(f"hydrobake: {obj.name}/{name} resumed after frame {job.runner.resumed_from}",
                  flush=True)
        for text in job.runner.effect.notes():
            print(f"hydrobake: {obj.name}/{name} note: {text}", file=sys.stderr, flush=True)
        print(f"hydrobake: {obj.name}/{name} {s.status.lower()} in "
              f"{time.monotonic() - t0:.1f}s -> {job.folder}", flush=True)
    # Overrides are for this run: the file keeps its own settings (and the bake's wiring).
    restore_overrides(undo)
    # Saved whenever a bake was recorded, even if others failed or a signal stopped the run:
    # the file must describe what is on disk (a renamed object's re-bake freed its old
    # folder; a cancelled bake's frames are there for resume).
    if (bpy.data.filepath and recorded and not getattr(args, "no_save", False)) and \
            not _save():
        return 1
    return 1 if failures else 0


def regress(args):
    from ..core import regress as rg
    tolerances = rg.load_tolerances(args.tolerances)  # checked before a long bake, not after
    if args.existing:
        new = args.existing
    else:
        out = args.output or os.path.abspath(os.path.join(args.report or bpy.app.tempdir,
                                                          "bake"))
        args.output, args.no_save = out, True
        code = bake(args)
        if code:
            return code
        # Bakes land in <output>/<blend name>/<object>_<effect>, the golden set's layout.
        stem = os.path.splitext(os.path.basename(bpy.data.filepath))[0] or "untitled"
        new = os.path.join(out, paths.folder_name(stem))
    # With a selection, only the selected bakes (the rest of the golden set was not baked).
    only = None if not (args.objects or args.effects) else {
        f"{paths.folder_name(obj.name)}_{name}" for obj, name in
        targets(args.objects, args.effects)}
    report = rg.compare(new, args.golden, tolerances, only=only)
    print(rg.summary(report), flush=True)
    if args.report:
        rg.write_report(report, args.report)
        print(f"hydrobake: report {os.path.join(args.report, 'report.html')}", flush=True)
    if not report["passed"]:
        print(f"hydrobake: {report['regressions']} regressions against {args.golden}",
              file=sys.stderr, flush=True)
    return 0 if report["passed"] else 1


def free(args):
    for obj, name in targets(args.objects, args.effects):
        folder = jobs.folder_of(obj, name)
        removed = jobs.free(bpy.context, obj, name)
        print(f"hydrobake: {obj.name}/{name} freed {len(removed)} files", flush=True)
        kept = jobs.kept_after_free(folder)
        if kept:
            print(f"hydrobake: {obj.name}/{name}: {kept}", file=sys.stderr, flush=True)
    if bpy.data.filepath and not _save():
        return 1
    return 0


def list_(args):
    known = effects.load_all()
    print(f"effects: {', '.join(sorted(known)) or 'none'}")
    for obj in bpy.data.objects:
        for name in known:
            s = getattr(obj, f"hydrobake_{name}", None)
            if s is not None and (s.enabled or s.is_baked):
                lib = obj.library or (obj.override_library and obj.override_library.reference
                                      and obj.override_library.reference.library)
                print(f"{obj.name}/{name}: enabled={s.enabled} baked={s.is_baked} "
                      f"folder={s.bake_folder or '-'}" +
                      (f" library={lib.filepath}" if lib else ""))
    return 0


def ensure_enabled():
    import addon_utils
    if "hydrobake" not in bpy.context.preferences.addons:
        addon_utils.enable("hydrobake", default_set=False)


def main(argv=None):
    """Runs one command; exits Blender with 0 on success, 1 on any failure."""
    try:
        args = parser().parse_args(_argv() if argv is None else argv)
    except SystemExit as exc:
        sys.exit(2 if exc.code else 0)
    try:
        ensure_enabled()
        commands = {"bake": bake, "resume": lambda a: bake(a, resume=True), "free": free,
                    "list": list_, "regress": regress}
        code = commands[args.command](args)
    except (errors.HydrobakeError, KeyError, ValueError, OSError) as exc:
        msg = exc.args[0] if isinstance(exc, KeyError) and exc.args else exc
        print(f"hydrobake: error: {msg}", file=sys.stderr, flush=True)
        code = 1
    sys.exit(code)
