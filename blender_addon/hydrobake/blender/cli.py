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
stdout a line per frame; errors go to stderr and the exit code is 1.
"""
import argparse
import json
import os
import sys
import time

import bpy

from ..core import errors
from . import effects, jobs


def _argv():
    argv = sys.argv
    return argv[argv.index("--") + 1:] if "--" in argv else []


def _frames(text):
    try:
        a, dash, b = text.partition("-")
        start, end = int(a), int(b) if dash else int(a)  # "5" is one frame; "5-" is a typo
    except ValueError:
        raise argparse.ArgumentTypeError(f"--frames {text!r}: must be START-END, e.g. 1-48")
    if start < 0 or end < start:
        raise argparse.ArgumentTypeError(f"--frames {text!r}: need 0 <= START <= END")
    return start, end


def _csv(text):
    return [t for t in text.split(",") if t]


def parser():
    p = argparse.ArgumentParser(prog="hydrobake", description="Hydrobake batch baking")
    sub = p.add_subparsers(dest="command", required=True)
    sub.add_parser("list", help="show effects, objects and bake state")
    for name in ("bake", "resume", "free", "regress"):
        s = sub.add_parser(name, help=f"{name} bakes")
        s.add_argument("--objects", type=_csv, help="comma-separated object names")
        s.add_argument("--effects", type=_csv, help="comma-separated effect names")
        if name != "free":
            s.add_argument("--frames", type=_frames, help="frame range START-END")
            s.add_argument("--output", help="cache folder override (absolute path)")
            s.add_argument("--threads", type=int, default=None,
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


def targets(objects=None, effect_names=None):
    """(object, effect name) pairs: named ones, else every enabled effect."""
    known = effects.load_all()
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
            if settings is None or not beffect.poll(obj):
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


def apply_overrides(pairs, path):
    """Sets parameters from a JSON file {"Object/effect" or "*/effect": {...}} (in memory);
    returns what they were, [(target, name, value)] in the order set (restore_overrides)."""
    undo = []
    if not path:
        return undo
    with open(path) as f:
        table = json.load(f)
    if not isinstance(table, dict) or not all(isinstance(v, dict) for v in table.values()):
        raise ValueError(f"--overrides {path}: must be a JSON object of objects "
                         '{"Object/effect": {"setting": value, ...}, ...}')

    def put(target, attr, value, where):
        was = getattr(target, attr)
        undo.append((target, attr, tuple(was) if hasattr(was, "__len__") and
                     not isinstance(was, str) else was))
        try:
            setattr(target, attr, value)
        except (TypeError, ValueError) as exc:  # Blender's: the type or length is wrong
            raise ValueError(f"--overrides {where}: {exc}") from None

    for obj, name in pairs:
        for key in (f"*/{name}", f"{obj.name}/{name}"):  # the object's own entry wins
            for attr, value in table.get(key, {}).items():
                settings = jobs.settings_of(obj, name)
                if isinstance(value, dict):
                    group = getattr(settings, attr, None)
                    if group is None:
                        raise KeyError(f"--overrides {key}: {attr} is not a setting")
                    for k, v in value.items():
                        if not hasattr(group, k):
                            raise KeyError(f"--overrides {key}: {attr}.{k} is not a parameter")
                        put(group, k, v, f"{key}: {attr}.{k}")
                elif hasattr(settings, attr):
                    put(settings, attr, value, f"{key}: {attr}")
                else:
                    raise KeyError(f"--overrides {key}: {attr} is not a setting")
    return undo


def restore_overrides(undo):
    for target, attr, value in reversed(undo):
        setattr(target, attr, value)


def bake(args, resume=False):
    failures = 0
    pairs = targets(args.objects, args.effects)
    undo = apply_overrides(pairs, getattr(args, "overrides", None))
    if not pairs:
        raise KeyError("nothing to bake: no object has an enabled Hydrobake effect "
                       "(use --objects and --effects)")
    for obj, name in pairs:
        t0 = time.monotonic()
        scene = obj.users_scene[0] if obj.users_scene else bpy.context.scene
        job = jobs.Job(bpy.context, obj, name, frames=args.frames, folder_override=args.output,
                       threads=args.threads, scene=scene, resume=resume)
        job.runner.on_frame = _print_frame(job, t0)
        jobs.ACTIVE[job.key] = job
        try:
            job.runner.run()
        except Exception as exc:  # report every target, then fail
            print(f"hydrobake: {obj.name}/{name} failed: {exc}", file=sys.stderr, flush=True)
            failures += 1
        finally:
            job.finalize(bpy.context)
        if job.runner.resumed_from is not None:
            print(f"hydrobake: {obj.name}/{name} resumed after frame {job.runner.resumed_from}",
                  flush=True)
        print(f"hydrobake: {obj.name}/{name} {job.runner.state.status.lower()} in "
              f"{time.monotonic() - t0:.1f}s -> {job.folder}", flush=True)
    # Overrides are for this run: the file keeps its own settings (and the bake's wiring).
    restore_overrides(undo)
    if bpy.data.filepath and not failures and not getattr(args, "no_save", False):
        bpy.ops.wm.save_mainfile()  # keeps is_baked and the wiring for renders
    return 1 if failures else 0


def regress(args):
    from ..core import regress as rg
    if args.existing:
        new = args.existing
    else:
        out = args.output or os.path.join(args.report or bpy.app.tempdir, "bake")
        args.output, args.no_save = out, True
        if bake(args):
            return 1
        # Bakes land in <output>/<blend name>/<object>_<effect>, the golden set's layout.
        stem = os.path.splitext(os.path.basename(bpy.data.filepath))[0] or "untitled"
        new = os.path.join(out, bpy.path.clean_name(stem))
    report = rg.compare(new, args.golden, rg.load_tolerances(args.tolerances))
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
        removed = jobs.free(bpy.context, obj, name)
        print(f"hydrobake: {obj.name}/{name} freed {len(removed)} files", flush=True)
    if bpy.data.filepath:
        bpy.ops.wm.save_mainfile()
    return 0


def list_(args):
    known = effects.load_all()
    print(f"effects: {', '.join(sorted(known)) or 'none'}")
    for obj in bpy.data.objects:
        for name in known:
            s = getattr(obj, f"hydrobake_{name}", None)
            if s is not None and (s.enabled or s.is_baked):
                print(f"{obj.name}/{name}: enabled={s.enabled} baked={s.is_baked} "
                      f"folder={s.bake_folder or '-'}")
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
