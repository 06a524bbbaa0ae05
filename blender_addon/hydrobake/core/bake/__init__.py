"""The bake framework shared by every effect: cache folders, manifests, atomic files and the
frame loop. Never imports bpy."""
from .cache import BakeCache, atomic_path, file_checksum  # noqa: F401
from .runner import BakeRunner, BakeState  # noqa: F401
