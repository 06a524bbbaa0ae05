"""What an effect gives the bake framework. Each effect is one module in this package built
on a C kernel; the Blender side (blender/effects/) feeds it inputs and wires its outputs."""


class Effect:
    """One effect's simulation for one object.

    Subclasses set ``name`` (e.g. "caustics"), ``streams`` (output stream names, which are
    also the file-name stems), and implement ``step`` and ``outputs``. ``params`` is a dict
    of the kernel's parameters (validated by its ParamSpec); ``inputs`` carries arrays taken
    from the scene (ground height, masks, meshes), prepared by the Blender bridge."""

    name = ""
    streams = ()
    spec = None  # ParamSpec of the kernel

    def __init__(self, params=None, inputs=None):
        self.params = self.spec.to_struct(params or {}) if self.spec else None
        self.inputs = dict(inputs or {})

    @property
    def seed(self):
        return int(getattr(self.params, "seed", 0)) if self.params is not None else 0

    def params_dict(self):
        return self.spec.to_dict(self.params) if self.spec else {}

    def step(self, frame, progress):
        """Advances the simulation to ``frame``. ``progress`` is the hbk_progress_t to pass to
        long C calls (they poll its cancel flag and raise Cancelled)."""
        raise NotImplementedError

    def outputs(self, frame):
        """{stream: (kind, payload, options)} for the frame just stepped; kind is "exr"
        (payload: channel name -> (h, w) float32), "vdb" (payload: list of grid dicts) or
        "npz" (payload: name -> array)."""
        raise NotImplementedError

    def close(self):
        """Frees the C handles; calling it twice is harmless."""
