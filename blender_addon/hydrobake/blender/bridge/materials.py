"""Small helpers for wiring baked maps into node materials non-destructively: every node
Hydrobake adds is labelled, so it can be found again and removed by Free Bake."""
import contextlib
import functools
import re

import bpy

TAG = "hydrobake"
OWNER = "hydrobake_owner"  # the object whose bake added the node, where several may wire one
ANY = object()  # remove_tagged: whoever added the node


MADE = "hydrobake_made"  # on a material ensure_material made and gave the object
SAVED = "hydrobake_saved"  # on a material: the values set_inputs replaced, by input name
NODES_WERE_OFF = "hydrobake_nodes_were_off"  # use_nodes() turned its nodes on
SETTINGS_WERE = "hydrobake_settings_were"  # the material settings see_through() changed
SHARED_AS = "hydrobake_shared_as"  # on a shared material own() copied: its copies' COPY_OF
# (COPY_OF and the rest of own()'s records: below, with own())


def follow_renames():
    """The copies' COPY_OF follow their shared material's new name when the artist renames
    it while a bake's copy stands for it (before, Free took it for gone and left the copy in
    its place under the old name, cut off from the artist's). A material marked SHARED_AS
    that no longer has that name is the renamed one, unless another marked alike keeps it:
    those are the artist's duplicates of it (Blender copies custom properties), whose mark
    goes; where none keeps it and several could be it, nothing is guessed. A mark no copy
    records goes."""
    marked, recorded = {}, {}
    for m in bpy.data.materials:
        if COPY_OF in m:
            recorded.setdefault(m[COPY_OF], []).append(m)
        elif SHARED_AS in m:
            marked.setdefault(m[SHARED_AS], []).append(m)
    for was, mats in marked.items():
        copies = recorded.get(was, [])
        shared = _shared_renamed(was, mats) if copies else None
        if copies and shared is None:
            continue  # (several could be it)
        for m in mats:
            if m != shared:
                del m[SHARED_AS]
        if shared is not None and shared.name != was:
            shared[SHARED_AS] = shared.name
            for copy in copies:
                copy[COPY_OF] = shared.name
                if copy.name == f"{was} ({copy.get(COPY_FOR)})":  # (own()'s name for it)
                    copy.name = _free_name(f"{shared.name} ({copy[COPY_FOR]})")


def _shared_renamed(was, mats):
    """Which of the materials marked SHARED_AS ``was`` is the one own() copied: the one
    still named so, else the only one, else the only one not named as Blender names a
    duplicate of it (``was.001``); None if several could be."""
    named = bpy.data.materials.get(was)
    if named in mats:
        return named
    fresh = [m for m in mats if not re.fullmatch(re.escape(was) + r"\.\d{3}", m.name)]
    return mats[0] if len(mats) == 1 else fresh[0] if len(fresh) == 1 else None


def _following_renames(func):
    """follow_renames() before ``func`` reads the copies' COPY_OF, and after it, for the
    marks of the copies it removed."""
    @functools.wraps(func)
    def wrapper(*args, **kwargs):
        follow_renames()
        try:
            return func(*args, **kwargs)
        finally:
            follow_renames()
    return wrapper


def ensure_material(obj, name, nodes=True):
    """The material the object's first slot renders with (its mesh's or, linked to the
    object, its own), or a new node material ``name`` given to it; with its nodes on, unless
    ``nodes`` is False (a caller that gives the object its own copy first: own())."""
    # The mesh's list says whether there is a slot: the object's slots can lag behind it,
    # more (a slot removed through another object of the mesh) or fewer (monkey --scene
    # --external 918, after slots tidied through another): those it lacks are given it.
    if len(obj.material_slots) < len(obj.data.materials):
        _sync_slots(obj)
    has_slot = len(obj.data.materials) > 0 and len(obj.material_slots) > 0
    mat = obj.material_slots[0].material if has_slot else None
    if mat is None:
        mat = bpy.data.materials.get(name) or bpy.data.materials.new(name)
        if has_slot:
            # The mesh's slot another bake appended, kept empty for another object of the
            # mesh (EMPTY_SLOT), is Hydrobake's: it goes with this material too (monkey 7284).
            ours = obj.material_slots[0].link == "DATA" and obj.data.get(EMPTY_SLOT) == 0
            obj.material_slots[0].material = mat
            mat[MADE] = "appended" if ours else "slot"
        else:
            obj.data.materials.append(mat)
            mat[MADE] = "appended"
    if nodes:
        use_nodes(mat)
    return mat


def _sync_slots(obj):
    """Gives the object the slots of its mesh it lacks: Blender resizes every object of a
    mesh whose list of materials grows or shrinks (and only then)."""
    obj.data.materials.append(None)
    obj.data.materials.pop()


def use_nodes(mat):
    """Turns the material's nodes on, remembering if they were off (give_back)."""
    if not mat.use_nodes:
        mat[NODES_WERE_OFF] = 1
        mat.use_nodes = True


def see_through(mat, blend=False):
    """The material's EEVEE settings for a refracting surface: Screen Space Refraction on
    (else EEVEE and the viewport draw the water or glass opaque grey, hiding the caustics
    under it), and with ``blend`` the Blend mode (a windshield, with the whole scene behind
    it). Cycles reads neither. What they were is kept until no bake is left in the material
    (give_back)."""
    want = {"use_screen_refraction": True}
    if blend:
        want["blend_method"] = "BLEND"
    were = mat[SETTINGS_WERE].to_dict() if SETTINGS_WERE in mat else {}
    for k, v in want.items():
        if getattr(mat, k) != v:
            were.setdefault(k, getattr(mat, k))
            setattr(mat, k, v)
    if were:
        mat[SETTINGS_WERE] = were


def set_inputs(mat, shader, values, prefix):
    """Sets a shader node's inputs {name: value} the first time the effect (role ``prefix``)
    wires the material, and keeps the values they replace, per effect, for give_back(); a
    re-bake keeps the user's later edits."""
    saved = mat[SAVED].to_dict() if SAVED in mat else {}
    if prefix in saved:
        return

    def plain(v):
        return float(v) if isinstance(v, (int, float)) else tuple(v)
    saved[prefix] = {"node": shader.name,
                     "values": {k: plain(shader.inputs[k].default_value) for k in values}}
    mat[SAVED] = saved
    for k, v in values.items():
        shader.inputs[k].default_value = v


def _has_wiring(mat):
    return bool(mat.node_tree) and any(n.get(TAG) for n in mat.node_tree.nodes)


def _wiring(mat):
    """The material's Hydrobake nodes, as (role, owner, image) each."""
    return {(n[TAG], n.get(OWNER), getattr(getattr(n, "image", None), "name", None))
            for n in (mat.node_tree.nodes if mat.node_tree else ()) if n.get(TAG)}


def give_back(obj, mat, prefix, deleted=False):
    """Free Bake's undo of set_inputs for the effect (role ``prefix``), once none of its
    nodes is left in ``mat`` (one of ``obj``'s, or None); and, once no Hydrobake node of any
    effect is left, of use_nodes and ensure_material: the nodes get their off switch back,
    and a material made for the object leaves its slot (and the file, with no other user).
    ``deleted``: the bake's object was deleted and no object records the bake (forget)."""
    tree = mat.node_tree
    if tree and any(str(n.get(TAG, "")).startswith(prefix) for n in tree.nodes):
        return
    saved = mat[SAVED].to_dict() if SAVED in mat else {}
    if saved and not all(isinstance(v, dict) and "values" in v for v in saved.values()):
        # The first format (one effect's values, flat, Principled): read as this effect's.
        shader = principled(tree) if tree else None
        saved = {prefix: {"node": shader.name if shader else "", "values": saved}}
    if prefix in saved:
        mine = saved[prefix]
        node = tree.nodes.get(mine["node"]) if tree else None
        later = list(saved)[list(saved).index(prefix) + 1:]
        for k, v in mine["values"].items():
            # An effect that set the input after this one saved this one's value: it gets
            # the value from before both, for its own Free (monkey --more --elsewhere 3897).
            heir = next((saved[p] for p in later if saved[p]["node"] == mine["node"] and
                         k in saved[p]["values"]), None)
            if heir is not None:
                heir["values"][k] = v
            elif node is not None and k in node.inputs:
                node.inputs[k].default_value = v
        del saved[prefix]
        if saved:
            mat[SAVED] = saved
        else:
            del mat[SAVED]
    if _has_wiring(mat) or saved:
        return  # another effect's bake is still in it
    if NODES_WERE_OFF in mat:
        mat.use_nodes = False
        del mat[NODES_WERE_OFF]
    if SETTINGS_WERE in mat:
        for k, v in mat[SETTINGS_WERE].to_dict().items():
            setattr(mat, k, v)
        del mat[SETTINGS_WERE]
    if MADE in mat:
        _let_go_made(obj, mat, prefix, deleted)


def _let_go_made(obj, mat, prefix, deleted=False):
    """A material made for a bake, wired by none now, out of the object's slot (``obj``
    may be None: deleted) and out of the file if nothing else uses it. A Shift+D copy that
    holds no bake of the effect and shows it alone: it goes there too (while a copy holds the
    bake's record, the mark stays for its own Free; another effect's Free would never give
    it back: monkey seed 477). A deleted object's bake (``deleted``) is recorded by none:
    the material leaves every slot (a baked Alt+D copy shows its own copy of another made
    material over it: monkey --more --delete-baked --elsewhere 7147)."""
    # The bake being freed: a copy keeping its record shows the material for its own Free.
    # A bake of another folder is another object's own (a Shift+D copy re-baked, or one made
    # while a shared mesh showed the material): it goes there too (monkey seed 3783).
    folder = _bake_folder(obj, prefix)
    if obj is not None:
        _take_out(obj, mat)
    for other in bpy.data.objects:
        if other != obj and (deleted or not _holds_bake(other, prefix, folder)):
            in_mesh = mat in list(getattr(other.data, "materials", None) or ())
            _take_out(other, mat)
            if in_mesh:  # a Shift+D copy's mesh keeps the original's empty-slot mark (7176)
                _drop_empty_slot(other)
    if _unused(mat):
        _free(mat, obj)


def unrecorded_made(mat):
    """Whether ``mat`` is a material ensure_material made that no bake wires, holds no
    effect's saved values, and that no copy own() made stands for."""
    return MADE in mat and mat.library is None and not _has_wiring(mat) and \
        SAVED not in mat and not any(m.get(COPY_OF) == mat.name for m in bpy.data.materials)


def let_go_deleted_made(mat, prefix):
    """A made material of a deleted object's bake out of every slot, and out of the file if
    nothing else uses it (as forget would, had the wiring been left to find it)."""
    _let_go_made(None, mat, prefix, deleted=True)


def _bake_folder(obj, prefix):
    """The folder of the object's bake of the effect whose nodes' role is ``prefix``; None
    if it holds none (or ``obj`` is None: deleted)."""
    own = getattr(obj, f"hydrobake_{prefix.rstrip('.')}", None) if obj and prefix else None
    return own.bake_folder if own is not None and own.is_baked else None


def _free(mat, obj):
    """Removes ``mat`` from the file, once out of reach of what Blender 3.4 leaves of the
    objects' own materials past their slots. Removing a slot, on any object of the mesh,
    keeps the object's own material of the last one in the object's list beyond its slots; a
    slot added later shows it again: freed, a segfault (monkey --more --delete-baked
    --elsewhere 7215). Shift+D copies that list whole, so any object copied from one that
    held it may hold it too (every flag + --relations 144): each object's list is cleared,
    not only ``obj``'s. Whether it was removed: not while an object is in Edit, Sculpt or a
    paint mode (it waits, used by nothing, for a save to drop it)."""
    held = [o for o in bpy.data.objects
            if o.type == "MESH" and o.data is not None and len(o.material_slots) and
            o.library is None and o.override_library is None]  # (their data is not ours)
    if any(o.mode != "OBJECT" for o in held):
        return False
    for o in held:
        _clear_past_slots(o)
    bpy.data.materials.remove(mat)
    return True


def _clear_past_slots(obj):
    """Empties the object's list of own materials past its slots: given an empty mesh for a
    moment, the object frees the list (Blender keeps it while any slot is left), and its
    slots' Links and own materials (shown, or behind the mesh's) are put back after. (Taken
    out first: freeing the list keeps their users.)"""
    mesh, active = obj.data, obj.active_material_index
    # (Blender sets a Multires modifier's levels to its total when the mesh comes back)
    levels = [(m, m.levels, m.sculpt_levels, m.render_levels) for m in obj.modifiers
              if m.type == "MULTIRES"]
    slots = []
    for s in obj.material_slots:
        link = s.link
        with _hidden(s, "OBJECT"):
            slots.append((link, s.material))
            s.material = None
    empty = bpy.data.meshes.new("HBK empty")
    try:
        obj.data = empty
    finally:
        obj.data = mesh
        bpy.data.meshes.remove(empty)
    for slot, (link, mat) in zip(obj.material_slots, slots):
        slot.link = "OBJECT"
        slot.material = mat
        slot.link = link
    obj.active_material_index = active
    for m, *was in levels:
        m.levels, m.sculpt_levels, m.render_levels = was


def take_out_made(mats, objs):
    """The materials ensure_material made among ``mats``, wired by no bake now, taken out of
    the objects' slots, shown or behind a slot's Link (give_back then removes them)."""
    for mat in mats:
        if MADE in mat and not _has_wiring(mat):
            for obj in dict.fromkeys(objs):
                _take_out(obj, mat)


def _unused(mat):
    """Nothing uses the material but meshes nothing uses (a deleted object's: a save drops
    them)."""
    if mat.users == 0:
        return True
    return not mat.use_fake_user and all(
        isinstance(u, bpy.types.Mesh) and u.users == 0
        for u in bpy.data.user_map(subset=[mat])[mat])


EFFECT_SETTINGS = ("hydrobake_caustics", "hydrobake_rain", "hydrobake_snow",
                   "hydrobake_fluid")


def _holds_bake(obj, prefix=None, folder=None):
    """Whether the object holds a bake of the effect whose nodes' role is ``prefix`` (of any
    effect, without one); with ``folder``, the bake in that folder only."""
    names = [f"hydrobake_{prefix.rstrip('.')}"] if prefix else EFFECT_SETTINGS
    for n in names:
        s = getattr(obj, n, None)
        if getattr(s, "is_baked", False) and (folder is None or s.bake_folder == folder):
            return True
    return False


def _take_out(obj, mat):
    """Takes a material ensure_material made (``mat``) out of the object's slot: the slot
    empty again, or gone if it was appended for it. Out of every slot showing it: the artist
    may have moved it down the list, and a resume then filled the first slot with it again
    (monkey --relations 30); the slots stay then, emptied, as which was appended is unknown."""
    indices = [i for i, s in enumerate(obj.material_slots) if s.material == mat]
    if not indices:
        _take_out_of_mesh(obj, mat)
        return
    appended = mat[MADE] == "appended" and len(indices) == 1
    for index in indices:
        obj.material_slots[index].material = None
    index = indices[0]
    # A mesh other objects share keeps the slot where one of them shows its own material.
    others = [o for o in bpy.data.objects if o != obj and o.data == obj.data]
    kept = any(
        index < len(o.material_slots) and o.material_slots[index].link == "OBJECT" and
        o.material_slots[index].material is not None for o in others)
    if appended and kept:
        obj.data[EMPTY_SLOT] = index  # for the last object showing it (restore)
    if appended and obj.material_slots[index].link == "DATA" and not kept and \
            index == len(obj.data.materials) - 1:
        _drop_slot(obj, index)
    _take_out_of_mesh(obj, mat)  # also where a Link hides it (both, monkey --more 1011)


def _take_out_of_mesh(obj, mat):
    """_take_out where a slot's Link hides ``mat``: the object's own material behind the
    mesh's (Link set back to Data since the bake; monkey --more 1030), emptied; or the mesh's
    behind the object's own (Link set to Object since, or an Alt+D copy's own; 1010, 1029,
    1006): the mesh's slot empty again, or gone if it was appended for the bake and no object
    of the mesh shows its own material there (else once none does)."""
    for slot in obj.material_slots:
        if slot.link == "DATA":  # the object's own material, behind the mesh's (1030)
            with _hidden(slot):
                if slot.material == mat:
                    slot.material = None
    mats = getattr(obj.data, "materials", None)
    index = next((i for i, m in enumerate(mats) if m == mat), None) if mats else None
    if index is None:
        return
    mats[index] = None
    shown = any(index < len(o.material_slots) and o.material_slots[index].link == "OBJECT"
                and o.material_slots[index].material is not None
                for o in bpy.data.objects if o.data == obj.data)
    if mat[MADE] == "appended" and shown:
        obj.data[EMPTY_SLOT] = index  # for the last object showing it (_drop_empty_slot)
    elif mat[MADE] == "appended" and index == len(mats) - 1:
        _drop_slot(obj, index)


@contextlib.contextmanager
def _hidden(slot, link=None):
    """The slot switched, for the block, to the other Link (or to ``link``): its material is
    then the one the slot's Link hides (the object's own behind the mesh's, or the other way
    round); the Link is put back after."""
    was = slot.link
    slot.link = link or ("OBJECT" if was == "DATA" else "DATA")
    try:
        yield slot
    finally:
        slot.link = was


def _drop_slot(obj, index):
    """Removes the mesh's slot ``index`` (the objects' slots with it) by the data API: no
    operator, so that it works on a hidden object, one in no view layer, or not active. An
    object's own material there, hidden by a Link set to Data, goes with it (it kept a user:
    monkey --more 1069), and leaves the file if it was a copy own() made or made for a bake
    and nothing else uses it."""
    hidden = []
    for o in bpy.data.objects:
        if o.data == obj.data and index < len(o.material_slots):
            with _hidden(o.material_slots[index], "OBJECT") as slot:
                if slot.material is not None:
                    hidden.append(slot.material)
                    slot.material = None
    if len(obj.data.materials) == 1:
        # Popping the last one leaves the objects' slot (Blender resizes their lists only
        # while some are left); clearing the list resizes them.
        obj.data.materials.clear()
    else:
        obj.data.materials.pop(index=index)
    for mat in dict.fromkeys(hidden):
        if (COPY_OF in mat or MADE in mat) and mat.users == 0 and not _has_wiring(mat):
            _free(mat, obj)


def holding(prefix, image_names, owner=ANY):
    """The file's materials whose Hydrobake nodes of an effect (role ``prefix``; added for
    ``owner``, if given) show one of ``image_names``: a bake's wiring wherever its materials
    are now (taken out of the object's slots, or a shared one it was re-baked past)."""
    names = set(image_names)
    found = []
    for mat in bpy.data.materials:
        if mat.node_tree and any(
                str(n.get(TAG, "")).startswith(prefix) and
                (owner is ANY or n.get(OWNER) == owner) and
                getattr(n, "image", None) is not None and n.image.name in names
                for n in mat.node_tree.nodes):
            found.append(mat)
    return found


def every_material(obj):
    """The materials the object has in any form: shown in its slots, behind a slot's Link
    (the mesh's, or its own behind the mesh's), and the shared ones its copies (own()) stand
    for and a Free would put back."""
    mats = {s.material for s in obj.material_slots}
    mats.update(getattr(obj.data, "materials", None) or ())
    if obj.library is None:  # (a linked object's Link cannot be switched, even for a look)
        for slot in obj.material_slots:
            if slot.link == "DATA":
                with _hidden(slot):
                    mats.add(slot.material)
    mats.discard(None)
    todo = list(mats)
    while todo:
        shared = bpy.data.materials.get(todo.pop().get(COPY_OF, ""))
        if shared is not None and shared not in mats:
            mats.add(shared)
            todo.append(shared)
    return mats


def shown_bakes(prefix, streams, mats=None):
    """The names of the bakes whose images (``HBK_<name>_<stream>``) the materials (default:
    the file's) show in Hydrobake nodes of an effect (role ``prefix``)."""
    pattern = re.compile(rf"HBK_(.+)_(?:{'|'.join(map(re.escape, streams))})")
    found = set()
    for mat in bpy.data.materials if mats is None else mats:
        for n in mat.node_tree.nodes if mat is not None and mat.node_tree else ():
            image = getattr(n, "image", None)
            match = pattern.fullmatch(image.name) if image is not None and \
                str(n.get(TAG, "")).startswith(prefix) else None
            if match:
                found.add(match.group(1))
    return found


@_following_renames
def forget(name, prefix, image_names, unwire):
    """Takes the wiring of a deleted object's bake (wired under ``name``; the materials
    showing one of ``image_names`` in nodes of role ``prefix``) out of the file's materials,
    as its Free Bake would have: unwire(node_tree), give_back. The object's own copies of
    shared materials (own()), used by nothing now, go."""
    for mat in holding(prefix, image_names):
        unwire(mat.node_tree)
        give_back(None, mat, prefix, deleted=True)
    for copy in [m.name for m in bpy.data.materials if m.get(COPY_FOR) == name]:
        mat = bpy.data.materials.get(copy)  # (one removed may have taken another with it)
        if mat is not None and not _has_wiring(mat) and _unused(mat):
            _remove_copy(mat, prefix, None, deleted=True)
    put_back_others(prefix)  # clean copies that stood for them while they were wired


def _remove_copy(mat, prefix, obj, deleted=False):
    """Removes ``mat``, used by nothing and wired by no bake. A clean copy own() made of a
    material made for the bake (an Alt+D copy showed it) takes that one with it, as the Free
    of the object the copy was for (``obj``, None if deleted) would have with the copy in its
    slot: out of Shift+D copies' slots too, unless a baked object's copy still stands for it
    (monkey --more --delete-baked 1673; the mesh's slot removed since: --elsewhere 7176)."""
    shared = bpy.data.materials.get(mat[COPY_OF]) if COPY_OF_MADE in mat else None
    if not _free(mat, obj):
        return
    if shared is not None and MADE in shared and not _has_wiring(shared) and \
            SAVED not in shared and not _stood_for(shared, obj):
        _let_go_made(obj, shared, prefix, deleted)


COPY_OF = "hydrobake_copy_of"  # on a material own() made: the shared one it stands for
COPY_FOR = "hydrobake_copy_for"  # ... and the object it was made for
LINK_WAS = "hydrobake_link_was"  # ... put on the object's own slot of a shared mesh
EMPTY_SLOT = "hydrobake_empty_slot"  # on a mesh: the slot a made material left, others using it
COPY_OF_MADE = "hydrobake_copy_of_made"  # on a copy own() made of a made material: its MADE
BEHIND = "hydrobake_behind"  # ... over the object's own, the mesh's hid: held till put back
COPY_FROM = "hydrobake_copy_from"  # ... of another copy: that copy's name


@_following_renames
def own(obj, index, unwire):
    """The material in the object's slot ``index``, made the object's own first if another
    object uses it too: a bake wires the object's own images into it, and two objects'
    bakes in one material overwrote each other. The copy, '<name> (<object>)', records the
    shared material, which restore() puts back; on a mesh other objects share (a linked
    duplicate) it goes on the object's own slot. A copy made for another object (a duplicate
    of a baked object shows it) is copied again. unwire(node_tree) takes another object's
    wiring of the effect out of the copy."""
    slot = obj.material_slots[index] if index < len(obj.material_slots) else None
    mat = slot.material if slot is not None else None
    if mat is None or mat.get(COPY_FOR) == obj.name:
        return mat
    if COPY_OF not in mat and not _used_elsewhere(obj, mat):
        return mat
    shared = mat.get(COPY_OF, mat.name)
    original = bpy.data.materials.get(shared)
    if original is not None and COPY_OF not in original and original.library is None:
        original[SHARED_AS] = shared  # found again if the artist renames it (follow_renames)
    copy = _copy(mat)
    if SHARED_AS in copy:
        del copy[SHARED_AS]
    copy.name = _free_name(f"{shared} ({obj.name})")
    copy[COPY_OF], copy[COPY_FOR] = shared, obj.name
    if COPY_OF in mat:
        copy[COPY_FROM] = mat.name
    elif COPY_FROM in copy:
        del copy[COPY_FROM]
    if MADE in mat:  # gone with its bake, it leaves the copy nothing to go back to
        copy[COPY_OF_MADE] = mat[MADE]
    # The original's record, not the copy's (what another object's copy went over, too:
    # this object's copy from before a rename keeps it, though another object took its old
    # name: the object's own material behind the mesh's comes back with Free, not None).
    # The nodes' switch stays: a copy of a material another bake turned them on in looks
    # like the artist's once clean, and is the artist's material if the original leaves the
    # file (every flag + --relations 120).
    renamed = COPY_FOR in mat and _for_no_other(obj, mat)
    for key in (MADE,) + (() if renamed else (BEHIND,)):
        if key in copy:
            del copy[key]
    # The record of an object's own slot (another's, or a deleted one's the artist gave this
    # slot) holds here only on this object's own slot where its mesh shows the shared
    # material (a Shift+D copy of a baked object): Free switching the Link back shows what
    # the slot showed before. Elsewhere Free puts the shared material in the slot as it is
    # (every flag + --scene --external 950), or, in the mesh's slot, the copy becomes the
    # shared one again if that left the file (--relations 133).
    if LINK_WAS in copy and (slot.link != "OBJECT" or _mesh_stands_for(obj, index) != shared):
        del copy[LINK_WAS]
    if copy.node_tree:  # (a material without nodes holds no wiring)
        unwire(copy.node_tree)  # another object's, if the shared material had it
    if slot.link == "DATA" and obj.data.users > 1:
        with _hidden(slot):
            if slot.material is not None:  # the object's own, kept behind the mesh's
                copy[BEHIND] = slot.material
        slot.link = "OBJECT"  # the mesh's slot would show it on every object of the mesh
        copy[LINK_WAS] = "DATA"
    slot.material = copy
    if COPY_OF in mat and mat.users == 0:  # this object's copy from before a rename
        _free(mat, obj)
    return copy


def _mesh_stands_for(obj, index):
    """The name of the material the object's mesh shows in slot ``index`` (of the one a
    clean copy there stands for), or None."""
    mats = getattr(obj.data, "materials", None) or ()
    mat = mats[index] if index < len(mats) else None
    return mat.get(COPY_OF, mat.name) if mat is not None else None


def _free_name(name):
    """``name``, or with the first free .NNN: Blender 3.4 gives an existing material a new
    name when a copy (``X.001``) is renamed to its name, and the artist's own material of
    that name came out of a bake renamed (monkey --moves 2)."""
    def cut(text, size):  # (a name holds 63 bytes)
        return text.encode()[:size].decode(errors="ignore")
    k, free = 0, cut(name, 63)
    while bpy.data.materials.get(free) is not None:
        k += 1
        free = f"{cut(name, 63 - len(f'.{k:03d}'))}.{k:03d}"
    return free


def _used_elsewhere(obj, mat):
    """Whether an object other than ``obj`` shows ``mat``, or holds it behind a slot's Link
    (another mesh's slot under its own material, or its own under the mesh's): the wiring
    would show there once the Link is switched (monkey --more 1611: a Shift+D copy's mesh
    kept a deleted object's made material behind the copy's own slot)."""
    if any(o != obj and any(s.material == mat for s in o.material_slots)
           for o in bpy.data.objects):
        return True
    for user in bpy.data.user_map(subset=[mat])[mat]:
        if isinstance(user, bpy.types.Object) and user != obj:
            return True
        # (a deleted object's mesh, used by none, waits for the save: it shows nothing)
        if isinstance(user, bpy.types.Mesh) and user != obj.data and user.users > 0:
            return True
    return False


def _copy(mat):
    """mat.copy(), without the extra user Blender 3.4 gives every image its image nodes show
    (one too many: a bake's images outlived its Free Bake, and the file's images their last
    user): the nodes are copied without their images, then given them."""
    held = [(n.name, n.image) for n in mat.node_tree.nodes
            if n.type in ("TEX_IMAGE", "TEX_ENVIRONMENT") and n.image is not None] \
        if mat.node_tree else []
    for name, _img in held:
        mat.node_tree.nodes[name].image = None
    try:
        copy = mat.copy()
    finally:
        for name, img in held:
            mat.node_tree.nodes[name].image = img
    for name, img in held:
        copy.node_tree.nodes[name].image = img
    return copy


@_following_renames
def restore(obj, prefix, made=None):
    """Undoes own() in the object's slots (Free Bake), unless the shared material holds
    another object's wiring of the same effect (then the object keeps its clean copy); and
    in other objects' slots, whose clean copies waited for the shared material to be free of
    this object's wiring (two objects sharing a material, both baked, both freed). ``made``:
    the name of the material this bake's ensure_material made (_let_go_behind)."""
    for slot in obj.material_slots:
        mat = slot.material
        if _mesh_slot_again(obj, slot):
            continue
        if _copy_of_gone_made(mat):
            _take_out_copy(obj, mat)
            continue
        if _copied_again(slot, obj) or _shared_again(mat):
            continue
        _put_shared_back(slot, prefix, obj)
    _claim_waiting(obj)
    _put_back_hidden(obj)
    if made is not None:
        _let_go_behind(obj, prefix, made)
        _let_go_unshown(obj, prefix, made)
    _drop_empty_slot(obj)
    put_back_others(prefix, but=obj)
    # A made material (or a clean copy own() made) taken out of its slot, and so out of the
    # bake's reach, while the bake was wired, and now wired by no bake: nothing else uses
    # it, it leaves the file.
    for name in [m.name for m in bpy.data.materials]:
        mat = bpy.data.materials.get(name)  # (one removed may have taken another with it)
        if mat is not None and (MADE in mat or COPY_OF in mat) and mat.users == 0 and \
                not _has_wiring(mat) and SAVED not in mat:
            _remove_copy(mat, prefix, obj)


def _claim_waiting(obj):
    """Clean copies left waiting in the object's slots (the shared material shows another
    bake) that were made for it under a name it has lost (renamed since): they record its
    name now. The record of the bake that knew the old name goes with this Free, and an
    object that took the old name would pass for the one the copy was made for, so a later
    Free left the slot's Link on Object (monkey every flag + all three + --renames 865)."""
    for slot in obj.material_slots:
        mat = slot.material
        if mat is not None and COPY_OF in mat and mat.get(COPY_FOR, obj.name) != obj.name \
                and _baked_as(obj, mat[COPY_FOR]):
            mat[COPY_FOR] = obj.name


def _put_back_hidden(obj):
    """Clean copies own() made that a slot's Link hides now (switched since the bake; monkey
    --more 1069), wired by no bake: behind the mesh's material, the object's own goes back to
    what own() went over (none, mostly); behind the object's own, the mesh's slot shows the
    shared material again (none if it is gone). A material made for a bake and hidden so,
    wired by none, goes to none, unless a baked object's copy stands for it (that bake's Free
    gives it back). A mesh's slot another object of the mesh shows is not hidden: what it
    shows goes back as that object's visible slots do (every flag + --relations 41, where
    an unrelated Free emptied an Alt+D copy's slot)."""
    for index, slot in enumerate(obj.material_slots):
        behind_mesh = slot.link == "DATA"
        if not behind_mesh and _mesh_slot_shown(obj, index):
            continue
        with _hidden(slot):
            mat = slot.material
            if mat is not None and COPY_OF in mat and not _has_wiring(mat):
                slot.material = mat.get(BEHIND) if behind_mesh else \
                    bpy.data.materials.get(mat[COPY_OF])
            elif mat is not None and MADE in mat and not _has_wiring(mat) and \
                    not _stood_for(mat, obj):
                slot.material = None  # (a Shift+D copy's, its Link switched: --more 1075)
            else:
                mat = None
        if mat is not None and mat.users == 0:
            _free(mat, obj)


def _let_go_behind(obj, prefix, made):
    """The material this bake made (named ``made``) in the mesh's slot behind the object's
    own (Link: Object), wired by none, where other objects of the mesh show it: the clean
    copy own() made of it, which held the wiring, left the file (the artist gave the slot
    another material, a save dropped the copy), and with it the one record that it goes with
    this Free. It goes as that copy's Free would have taken it, unless a baked object's copy
    still stands for it (every flag + --scene --external 950)."""
    for slot in obj.material_slots:
        if slot.link != "OBJECT":
            continue
        with _hidden(slot):
            mat = slot.material
        if mat is None or mat.name != made or MADE not in mat or _has_wiring(mat) or \
                any(s.material is not None and s.material.get(COPY_OF) == made
                    for s in obj.material_slots) or _stood_for(mat, obj):
            continue
        give_back(obj, mat, prefix)


def _let_go_unshown(obj, prefix, made):
    """The material this bake made (named ``made``), in none of the object's slots (Remove
    Unused Slots took its slot) but still shown by Shift+D copies that let go of the bake:
    it goes with the last Free of the bake, as it would have from the object's slot (every
    flag + --scene --external 984)."""
    mat = bpy.data.materials.get(made)
    folder = _bake_folder(obj, prefix)
    if mat is None or folder is None or not unrecorded_made(mat) or \
            mat in list(obj.data.materials) or \
            any(s.material == mat for s in obj.material_slots) or \
            any(o != obj and _holds_bake(o, prefix, folder) for o in bpy.data.objects):
        return
    _let_go_made(obj, mat, prefix)


def tidy_on_load():
    """What a Free would tidy in objects without a bake, done when a file opens: clean copies
    a slot's Link hides (_put_back_hidden), and rename marks no copy records any more. A save
    drops a material nothing uses, and with it what a copy waited for: the copy of a deleted
    object's made material behind a Link switched to Data stayed in the file with nothing
    left to put it back (monkey every flag + --relations 114)."""
    follow_renames()
    for obj in bpy.data.objects:
        if obj.library is None and obj.override_library is None and obj.type == "MESH" and \
                obj.data.library is None and not _holds_bake(obj):
            _put_back_hidden(obj)


def _mesh_slot_shown(obj, index):
    """Whether another object of the object's mesh shows the mesh's material in slot
    ``index`` (its Link: Data)."""
    return any(o != obj and o.data == obj.data and index < len(o.material_slots) and
               o.material_slots[index].link == "DATA" for o in bpy.data.objects)


def _stood_for(mat, obj):
    """Whether an object other than ``obj`` that holds a bake shows a clean copy own() made of
    ``mat`` (an Alt+D copy of a pool freed first keeps the mesh's made material its pool's
    copy stands for: monkey --more 1106)."""
    return any(o != obj and _holds_bake(o) and any(
        s.material is not None and s.material.get(COPY_OF) == mat.name
        for s in o.material_slots) for o in bpy.data.objects)


def _mesh_slot_again(obj, slot):
    """A clean copy in the object's own slot of a shared mesh, standing for a material made
    for another object of the mesh and gone with its bake: the mesh's slot shows again
    (empty, or gone with nothing shown there). Whether it did."""
    mat = slot.material
    if mat is None or COPY_OF not in mat or bpy.data.materials.get(mat[COPY_OF]) is not None \
            or _has_wiring(mat) or mat.get(LINK_WAS) != "DATA" or slot.link != "OBJECT":
        return False
    slot.material = mat.get(BEHIND)
    slot.link = "DATA"
    if mat.users == 0:
        _free(mat, obj)
    _drop_empty_slot(obj)
    return True


def _drop_empty_slot(obj, freed=None):
    """The mesh's slot a made material left (EMPTY_SLOT, kept while another object of the
    mesh showed its own material there) goes once no object of the mesh shows anything there
    (monkey --more 1009: the last of two Alt+D copies freed); it stays, empty and unmarked,
    where the artist's slots follow it. ``freed``: an object of the mesh being freed, whose
    bake no longer counts (monkey --more --elsewhere 3897)."""
    index = obj.data.get(EMPTY_SLOT) if obj.data is not None else None
    if index is None:
        return
    held = obj.data.materials[index] if index < len(obj.data.materials) else None
    if held is not None:
        # The mesh's slot filled again, hidden where every object of the mesh shows its own
        # there: by a bake (ensure_material), the slot goes with that material, not before (a
        # deleted object's, kept for Remove Deleted Objects' Bakes: every flag + --scene
        # 2137); by the artist, it stays.
        if MADE not in held and COPY_OF not in held:
            del obj.data[EMPTY_SLOT]
        return
    users = [o for o in bpy.data.objects if o.data == obj.data]
    shown = [o.material_slots[index].material for o in users
             if index < len(o.material_slots) and o.material_slots[index].material]
    if shown:
        if not any(COPY_OF in m or MADE in m for m in shown) and not any(
                o not in (obj, freed) and _holds_bake(o) for o in users):
            del obj.data[EMPTY_SLOT]  # the artist's own material there: no Free will come
        return
    del obj.data[EMPTY_SLOT]  # no object shows anything there: the slot goes, unless
    if index == len(obj.data.materials) - 1:  # the artist's slots follow it (monkey 1007)
        for o in users:
            o.material_slots[index].link = "DATA"
        _drop_slot(obj, index)


def drop_left_empty_slots():
    """_drop_empty_slot on every mesh still marked: the object it was kept for may be gone
    (deleted while baked, its Free never to come: monkey --more --delete-baked 1620)."""
    for mesh in bpy.data.meshes:
        if EMPTY_SLOT in mesh:
            obj = next((o for o in bpy.data.objects if o.data == mesh), None)
            if obj is not None:
                _drop_empty_slot(obj)


@_following_renames
def put_back_others(prefix, but=None):
    """The clean copies in the slots of objects other than ``but`` that waited for their
    shared material to be free of another object's wiring: the shared one back in its place,
    or (a made one, gone with that wiring) the copy out."""
    for other in bpy.data.objects:
        if other != but:
            for slot in list(other.material_slots):
                mat = slot.material
                if _mesh_slot_again(other, slot):
                    continue  # (its made one went with this Free: monkey --more 1006)
                if _copy_of_gone_made(mat) and mat.get(LINK_WAS) != "DATA":
                    _take_out_copy(other, mat)  # its made one went with this Free
                elif not _shared_again(mat):  # (its last wiring gone with this one: 767)
                    _put_shared_back(slot, prefix, other)
            if not _holds_bake(other):
                _put_back_hidden(other)  # (a freed Shift+D copy's, Link switched: 1062)
            # Its slot back to the mesh's, the mesh's empty one may go (an Alt+D pool whose
            # copy of the mesh's made material a Shift+D copy shares: monkey --more 3020).
            _drop_empty_slot(other, freed=but)


def _orphan_copy(mat):
    """Whether ``mat`` is a clean copy own() made of a shared (not made) material, in a slot
    whose Link it did not switch, and that shared material has left the file."""
    return mat is not None and COPY_OF in mat and COPY_OF_MADE not in mat and \
        not _has_wiring(mat) and mat.get(LINK_WAS) != "DATA" and \
        bpy.data.materials.get(mat[COPY_OF]) is None


def _copied_again(slot, obj):
    """A clean copy own() made of another clean copy, in a slot it did not switch, whose
    shared material has left the file: the slot shows that other copy again, as before the
    bake, if it is still in the file and clean (the artist gave it to other slots too).
    Become the shared material instead (_shared_again), it took the other copy's slots
    (every flag + --relations 144). Whether it did."""
    mat = slot.material
    if not _orphan_copy(mat) or COPY_FROM not in mat:
        return False
    before = bpy.data.materials.get(mat[COPY_FROM])
    if before is None or before == mat or before.get(COPY_OF) != mat[COPY_OF] or \
            COPY_OF_MADE in before or _has_wiring(before):
        return False
    slot.material = before
    if mat.users == 0:
        _free(mat, obj)
    return True


def _shared_again(mat):
    """A clean copy own() made, wired by no bake now, whose shared material left the file
    meanwhile (its slots changed, it had no user at a save) becomes that material again: its
    name back, no longer a copy (other copies of it then go back to it). Whether it did."""
    if not _orphan_copy(mat):
        return False
    mat.name = mat[COPY_OF]
    for key in (COPY_OF, COPY_FOR, COPY_FROM):
        if key in mat:
            del mat[key]
    return True


def _copy_of_gone_made(mat):
    """Whether ``mat`` is a clean copy own() made of a material made for another object,
    which has gone with that object's bake, or is held only by meshes of deleted objects (a
    save drops it with them: monkey --delete-baked 3184)."""
    if mat is None or COPY_OF_MADE not in mat or COPY_OF not in mat or _has_wiring(mat):
        return False
    made = bpy.data.materials.get(mat[COPY_OF])
    return made is None or _unused(made)


def _take_out_copy(obj, mat):
    """A copy of a material made for the object ``obj`` was copied from (Shift+D), the made
    one gone with its bake: made for ``obj`` as much, it goes as that one went."""
    mat[MADE] = mat[COPY_OF_MADE]
    _take_out(obj, mat)
    if mat.users == 0:
        _free(mat, obj)
    else:
        del mat[MADE]


def _put_shared_back(slot, prefix, obj):
    """The shared material back in the object's slot in place of a clean copy own() made,
    unless the shared one holds another object's wiring of the effect, or shows a bake the
    object holds no record of (of an object deleted while baked, its wiring left there) other
    than those the copy shows, or the copy holds the wiring of a bake some object holds."""
    mat = slot.material
    shared = bpy.data.materials.get(mat[COPY_OF]) if mat is not None and COPY_OF in mat \
        else None
    if shared is None:
        return
    # What the slot will show is judged: with the Link back on the mesh's, the mesh's
    # material, which may be another copy of the shared one (an Alt+D copy's, brought by a
    # Join), with another bake than the shared one shows (every flag + --obstacles 764).
    to_mesh = _back_to_mesh(slot, obj, mat)
    back = _mesh_material(obj, slot) if to_mesh else None
    shown = back if back is not None else shared
    if shown.node_tree and any(
            str(n.get(TAG, "")).startswith(prefix) for n in shown.node_tree.nodes):
        return  # another object's bake of the effect in the shared one
    if _wiring(shown) - _wiring(mat):
        # ... or of another effect, which the copy does not show: it waits for that one's
        # Free, not the next Free of any effect (a pool's floor nodes in a pool's shared
        # water material went on show with a snow object's bake: monkey --renames 2).
        return
    # Another effect's bake still in the copy waits for its own Free, unless the copy only
    # took it along from the shared one: a bake of an object deleted while baked, whose Free
    # never comes (every flag + --scene --external --relations 756). The shared one goes
    # back where it shows the same such bakes as the copy: none that the copy did not show,
    # and none of the copy's taken out with it.
    if (_has_wiring(mat) and not _only_deleted(mat)) or \
            _others_shown(shown, obj) != _others_shown(mat, obj):
        return
    # The Link record is the slot's of the object the copy was made for: another object the
    # artist gave the copy (Link Materials) gets the shared material in the slot as it is
    # (every flag + --scene 816). The object renamed since is found by its bake's name, not
    # its old one, which another object may have taken (monkey --more --delete-baked
    # --elsewhere --moves --scene 2106, 2108).
    if to_mesh:
        slot.material = mat.get(BEHIND)  # (None, mostly)
        slot.link = "DATA"  # the mesh's own material shows again
        # It may be a clean copy waiting too, freed of its bake by this Free (a copy the
        # artist gave the mesh, over which own() made this one): it goes back now, not at
        # some later Free (every flag + --relations 128).
        shown = slot.material
        if shown is not None and COPY_OF in shown and COPY_OF_MADE not in shown and \
                not _shared_again(shown):
            itself = shown == mat
            _put_shared_back(slot, prefix, obj)
            if itself:
                return  # the mesh's slot showed this very copy: that call put it back
                # (and removed it; every flag + --scene --external --relations 711)
    else:
        slot.material = shared
    if mat.users == 0:
        _free(mat, obj)
    if MADE in shared and not _has_wiring(shared) and SAVED not in shared:
        # Made for a bake and copied by own() at once (the mesh is shared, an Alt+D copy
        # showed it; monkey --more 1017), no bake in it now: it goes as give_back's would,
        # from Shift+D copies of those objects too (1056).
        _let_go_made(obj, shared, prefix)


def _back_to_mesh(slot, obj, mat):
    """Whether Free puts the slot's Link back on the mesh's material, in place of the copy
    ``mat`` own() made on the object's own slot."""
    return mat.get(LINK_WAS) == "DATA" and slot.link == "OBJECT" and _for_no_other(obj, mat)


def _mesh_material(obj, slot):
    """The material the object's mesh holds in ``slot``'s place, or None."""
    index = next(i for i, s in enumerate(obj.material_slots) if s == slot)
    mats = obj.data.materials
    return mats[index] if index < len(mats) else None


def _for_no_other(obj, mat):
    """Whether ``mat`` (a copy own() made) was made for no object in the file but ``obj``:
    for ``obj`` under its name, or under the name a bake of its own was made under (renamed
    since: another object may have taken the old name), or for one that is gone. (A Shift+D
    copy holds its original's record, with the original's name: not its own.)"""
    made_for = mat.get(COPY_FOR, "")
    return made_for == obj.name or bpy.data.objects.get(made_for) is None or \
        _baked_as(obj, made_for)


def _baked_as(obj, name):
    """Whether ``obj`` holds a bake of its own made under ``name``."""
    from .. import jobs  # (jobs imports the effects, which import this module)
    return any(getattr(obj, e).get("baked_as") == name and
               jobs.owns_record(obj, e[len("hydrobake_"):]) for e in EFFECT_SETTINGS)


def _held(obj):
    """The names the images of the bakes ``obj`` holds start with (HBK_<name>_...)."""
    return [getattr(obj, e).get("baked_as") or obj.name for e in EFFECT_SETTINGS
            if getattr(getattr(obj, e, None), "is_baked", False)]


def _of_held(image, held):
    """Whether the image's name is of one of the bakes named ``held`` (_held)."""
    return any(image.startswith(f"HBK_{h}_") for h in held)


def _others_shown(mat, obj):
    """The images of bakes ``obj`` holds no record of that the material's Hydrobake nodes
    show. (A floor's nodes, owned by their pool, show on whatever the floor material is
    given to.)"""
    held = _held(obj)
    return {n.image.name for n in (mat.node_tree.nodes if mat.node_tree else ())
            if n.get(TAG) and OWNER not in n and getattr(n, "image", None) is not None and
            not _of_held(n.image.name, held)}


def _only_deleted(mat):
    """Whether every Hydrobake node of the material is of bakes no object holds a record of
    (of objects deleted while baked): none owned by a pool, and some image shown, none of
    them a held bake's."""
    held = [h for o in bpy.data.objects for h in _held(o)]
    nodes = [n for n in (mat.node_tree.nodes if mat.node_tree else ()) if n.get(TAG)]
    images = [n.image.name for n in nodes if getattr(n, "image", None) is not None]
    return bool(images) and all(OWNER not in n for n in nodes) and \
        not any(_of_held(i, held) for i in images)


def tagged(node_tree, role, owner=None):
    """Hydrobake's node with ``role`` (added for ``owner``, or for no one) in this tree, or
    None."""
    for node in node_tree.nodes:
        if node.get(TAG) == role and node.get(OWNER) == owner:
            return node
    return None


def add_node(node_tree, bl_idname, role, location=(0, 0), label=None, owner=None):
    """Adds (or reuses) a node tagged with ``role``; ``owner`` names the object it is for,
    where one tree takes several objects' bakes (a floor under two pools)."""
    node = tagged(node_tree, role, owner)
    if getattr(node, "image", None) is not None:  # given the new bake's image next
        _let_go_of_image(node)
    if node is None or node.bl_idname != bl_idname:
        if node is not None:
            node_tree.nodes.remove(node)
        node = node_tree.nodes.new(bl_idname)
        node[TAG] = role
        if owner is not None:
            node[OWNER] = owner
    node.location = location
    node.label = label or (f"Hydrobake {role}" if owner is None else
                           f"Hydrobake {role} ({owner})")
    return node


def remove_tagged(node_tree, prefix="", owner=ANY):
    """Removes every Hydrobake node whose role starts with ``prefix`` (added for ``owner``
    only, if given: None for nodes added for no one), and a baked image one of them showed
    that nothing shows any more (a deleted object's, whose wiring another bake replaced);
    returns the count."""
    gone = [n for n in node_tree.nodes if isinstance(n.get(TAG), str) and
            n[TAG].startswith(prefix) and (owner is ANY or n.get(OWNER) == owner)]
    for n in gone:
        if getattr(n, "image", None) is not None:
            _let_go_of_image(n)
        node_tree.nodes.remove(n)
    return len(gone)


def _let_go_of_image(node):
    """Takes the image out of our image node, and removes it if it is a baked one nothing
    shows any more (a deleted object's, whose wiring another object's bake replaced)."""
    img, node.image = node.image, None
    if img.name.startswith("HBK_") and img.users == 0:
        bpy.data.images.remove(img)


def principled(node_tree):
    return next((n for n in node_tree.nodes if n.type == "BSDF_PRINCIPLED"), None)
