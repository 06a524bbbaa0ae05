"""Applies --overrides tables to the open file's targets in one Blender run, as the command line
does (cli.apply_overrides), and prints what each gave: a line per case,
"CASE <i> OK" or "CASE <i> ERROR <message>". Arguments: a JSON file of
[{"objects": [...], "effects": [...], "table": {...}}, ...]; a case's "show": a setting whose
value (a data-block's name) is printed for each target while the overrides hold ("SHOW
<object>/<effect> <setting> <value>") and after they are put back ("AFTER ...")."""
import json
import os
import tempfile

import in_blender

in_blender.enable()
from hydrobake.blender import cli  # noqa: E402

cases = json.load(open(in_blender.args()[0]))
folder = tempfile.mkdtemp()
for i, case in enumerate(cases):
    path = os.path.join(folder, f"case{i}.json")
    with open(path, "w") as f:
        f.write(case["table"] if isinstance(case["table"], str) else json.dumps(case["table"]))
    pairs = cli.targets(case.get("objects"), case.get("effects"))
    try:
        undo = cli.apply_overrides(pairs, path)
    except (KeyError, ValueError) as exc:
        msg = exc.args[0] if isinstance(exc, KeyError) else exc
        print(f"CASE {i} ERROR {msg}", flush=True)
    else:
        show = case.get("show")

        def shown(when):
            for obj, effect in pairs:
                value = getattr(getattr(obj, f"hydrobake_{effect}"), show)
                print(f"{when} {obj.name}/{effect} {show} {getattr(value, 'name', value)}")
        if show:
            shown("SHOW")
        cli.restore_overrides(undo)
        if show:
            shown("AFTER")
        print(f"CASE {i} OK", flush=True)
