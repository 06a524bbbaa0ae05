"""Objects a bake adds beside its object (a pool's projector and grid Empty, the falling
flakes, a fluid's surface and Volume), named ``HBK_<baked name>_<role>``. The artist may
rename them (the projector is a light in the Outliner like any other), so each also carries
its owner in a property: a re-bake updates the renamed one instead of adding a second, and
Free Bake finds it."""
import bpy

TAG = "hydrobake_helper"  # on the object: "<effect>|<baked name>|<role>"


def tag(obj, effect, name, role):
    obj[TAG] = f"{effect}|{name}|{role}"


def _tagged(effect, name, role, kind):
    want = f"{effect}|{name}|{role}"
    return [o for o in bpy.data.objects
            if o.library is None and o.type == kind and o.get(TAG) == want]


def _named(name, role, kind):
    named = bpy.data.objects.get(f"HBK_{name}_{role}")
    return named if named is not None and named.library is None and named.type == kind \
        else None


def every(effect, name, role, kind):
    """The helper (objects of type ``kind``) under the name apply gave it, then every object
    tagged as it (renamed since; a Shift+D copy of it shows the same bake, and goes with
    it)."""
    named = _named(name, role, kind)
    found = [named] if named is not None else []
    return found + [o for o in _tagged(effect, name, role, kind) if o not in found]


def find(effect, name, role, kind):
    """The helper: by its name, else by its tag (every's first); or None."""
    return next(iter(every(effect, name, role, kind)), None)


def owners(effect, roles):
    """The baked names whose helpers of these roles are in the file, by their tag (a
    library's are that file's)."""
    out = set()
    for o in bpy.data.objects:
        if o.library is not None:
            continue
        tagged = str(o.get(TAG, "")).split("|")  # (a name may hold a "|")
        if len(tagged) >= 3 and tagged[0] == effect and tagged[-1] in roles:
            out.add("|".join(tagged[1:-1]))
    return out
