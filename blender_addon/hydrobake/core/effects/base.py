"""What an effect gives the bake framework. Each effect is one module in this package built
on a C kernel; the Blender side (blender/effects/) feeds it inputs and wires its outputs."""


from .. import errors


def plain(value):
    """``value`` with tuples, numpy arrays and numpy scalars made JSON's lists and numbers
    (for scalar_inputs)."""
    if isinstance(value, dict):
        return {str(k): plain(v) for k, v in value.items()}
    if hasattr(value, "tolist"):  # numpy arrays and scalars
        value = value.tolist()
    if isinstance(value, (list, tuple)):
        return [plain(v) for v in value]
    return value


class Effect:
    """One effect's simulation for one object.

    Subclasses set ``name`` (e.g. "caustics"), ``streams`` (output stream names, which are
    also the file-name stems), and implement ``step`` and ``outputs``. ``params`` is a dict
    of the kernel's parameters (validated by its ParamSpec); ``inputs`` carries arrays taken
    from the scene (ground height, masks, meshes), prepared by the Blender bridge."""

    name = ""
    streams = ()
    # The runner may write a frame's files while the next frame is stepped (BakeRunner.run):
    # True only where ``outputs`` and ``save_state`` hand back arrays and bytes of their own,
    # which a later ``step`` never writes into.
    detached_outputs = False

    @classmethod
    def groups(cls):
        """{group name: ParamSpec}: the kernels' parameter tables, e.g. {"water": ...,
        "light": ...}. Parameters travel as {group: {name: value}}."""
        return {}

    def __init__(self, params=None, inputs=None):
        params = params or {}
        unknown = set(params) - set(self.groups())
        if unknown:
            raise errors.InvalidArgument(f"{sorted(unknown)[0]}: not a parameter group of "
                                         f"{self.name}; groups: {', '.join(self.groups())}")
        # Validated structs per group (raises InvalidArgument naming the parameter).
        self.params = {}
        for g, spec in self.groups().items():
            try:
                self.params[g] = spec.to_struct(params.get(g, {}))
            except errors.InvalidArgument as exc:  # say which group: "light.ior[0] = 0.5: ..."
                raise errors.InvalidArgument(f"{g}.{exc}") from None
        self.inputs = dict(inputs or {})

    @property
    def seed(self):
        for s in self.params.values():
            if hasattr(s, "seed"):
                return int(s.seed)
        return 0

    def params_dict(self):
        return {g: spec.to_dict(self.params[g]) for g, spec in self.groups().items()}

    def scalar_inputs(self):
        """The inputs besides ``params`` that shape every frame's output, as plain JSON
        values (e.g. {"map_size": [w, h], "substeps": 2}); arrays taken from the scene are
        not among them. The runner records them in the manifest beside the parameters, and
        a resume refuses to continue a bake whose values differ."""
        return {}

    def scene_inputs(self):
        """{name: arrays.digest()} of the arrays taken from the scene that shape every frame (the
        snow's mesh, the pool's ground), named for the artist ("mesh"). The runner records
        them in the manifest, and a resume refuses to continue a bake made from others: its
        frames and checkpoint hold the old ones' snow and water."""
        return {}

    def frame_inputs(self, frame):
        """{name: arrays.digest()} of what the step of ``frame`` takes from the scene's animation
        (where the snow's mesh is then, the wipers' angles), {} for none. The runner records
        them with each frame; a resume refuses to continue from a checkpoint whose frames were
        made from other ones (frames after it are baked again, from the scene as it is now)."""
        return {}

    def forecast(self, start, end):
        """What the artist should hear before baking frames ``start``..``end`` of what the bake
        will run into (a fluid's inflow that will fill it to max_particles, say): [] for
        nothing. Leaves the effect as it was."""
        return []

    def notes(self):
        """What the artist should hear of the frames stepped (a fluid's inflow that stopped at
        max_particles, say), reported when the bake ends: [] for nothing. Kept past close()."""
        return []

    def step(self, frame, progress):
        """Advances the simulation to ``frame``. ``progress`` is the hbk_progress_t to pass to
        long C calls (they poll its cancel flag and raise Cancelled)."""
        raise NotImplementedError

    def outputs(self, frame):
        """{stream: (kind, payload, options)} for the frame just stepped; kind is "exr"
        (payload: channel name -> (h, w) float32), "vdb" (payload: list of grid dicts) or
        "npz" (payload: name -> array)."""
        raise NotImplementedError

    def save_state(self):
        """The simulation state after the last step, as bytes, for checkpoints; None for an
        effect whose frames do not depend on earlier ones."""
        return None

    def load_state(self, data):
        """Restores a state from save_state(); the next step continues bit for bit."""
        raise NotImplementedError

    def close(self):
        """Frees the C handles; calling it twice is harmless."""
