"""Which files a scene may read: every file a scene names goes through `scene_file`.

A scene read with allow_outside=False (a service reading scenes written by
others) may read only files inside its own folder, symlinks followed: its
mesh files, the buffers a glTF file names, the materials and images a mesh
file names (trimesh reads those through `trimesh_resolver`), and any file a
later feature reads (textures) must be found through `scene_file` too, so the
rule lives in one place.
"""

from __future__ import annotations

import errno
from pathlib import Path

from ..errors import UsageError, shown


def scene_file(folder, name: str, root, what: str) -> Path:
    """The path of `name` relative to `folder`.  With a `root` (a confined scene) the path, symlinks
    followed, must lie inside `root`, else UsageError naming `what`; the resolved path is returned, so the
    file checked is the file read.  Without a root any path is allowed (local files) and is returned as given."""
    path = Path(folder) / name
    if root is None:
        return path
    try:
        resolved = path.resolve()
        base = Path(root).resolve()
    except (OSError, RuntimeError, ValueError) as exc:  # a symlink loop (RuntimeError before Python 3.13), a NUL byte
        reason = "a symlink loop" if isinstance(exc, RuntimeError) or getattr(exc, "errno", None) == errno.ELOOP else type(exc).__name__
        raise UsageError(f"{what}: {shown(name)} cannot be resolved ({reason}); allowed: files inside the scene folder") from None
    if not resolved.is_relative_to(base):
        raise UsageError(f"{what}: {shown(name)} is outside the scene folder {shown(str(base))}; allowed: paths inside it")
    return resolved


def trimesh_resolver(mesh_path: Path, root):
    """A trimesh resolver for `mesh_path` that reads only files inside `root` (through `scene_file`) as
    well as inside the mesh's own folder (trimesh's rule).  A refusal is a UsageError, which is the
    ValueError trimesh expects of a resolver, so trimesh tries its other spellings of the name and then raises it."""
    import trimesh

    class Confined(trimesh.resolvers.FilePathResolver):
        def absolute(self, name: str) -> Path:
            scene_file(self.parent, name.strip(), root, str(mesh_path))
            return super().absolute(name)

        def namespaced(self, namespace: str):
            return Confined(str(Path(self.parent) / namespace))

    return Confined(str(mesh_path))
