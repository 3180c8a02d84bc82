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
import os
import stat
from pathlib import Path

from ..errors import UsageError, shown
from .image_files import image_header


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


def trimesh_resolver(mesh_path: Path, root, refusals: list | None = None):
    """A trimesh resolver for `mesh_path` that reads only files inside `root` (through `scene_file`) as
    well as inside the mesh's own folder (trimesh's rule), and only regular files whose size fits (`asset_bytes`:
    a FIFO named by `mtllib` or `map_Kd` would block the read forever).  A refusal is a UsageError, which is the
    ValueError trimesh expects of a resolver, so trimesh tries its other spellings of the name and then raises it;
    trimesh's OBJ reader then drops the asset, so the size and kind refusals are also appended to `refusals`, for
    the caller to raise once trimesh returns (mesh_files.load_mesh_file)."""
    import trimesh

    refusals = [] if refusals is None else refusals

    class Confined(trimesh.resolvers.FilePathResolver):
        def absolute(self, name: str) -> Path:
            scene_file(self.parent, name.strip(), root, str(mesh_path))
            return super().absolute(name)

        def namespaced(self, namespace: str):
            return Confined(str(Path(self.parent) / namespace))

        def get(self, name: str):
            for candidate in (name.strip(), name.strip().lstrip("/"), os.path.split(name)[-1]):  # trimesh's spellings
                try:
                    path = self.absolute(candidate)
                except ValueError:
                    continue
                if os.path.lexists(path):
                    try:
                        return read_asset(path, f"{mesh_path}: {shown(name.strip())}")
                    except UsageError as exc:
                        refusals.append(exc)
                        raise
            return super().get(name)  # trimesh's own error for a name that is missing or escapes the folder

    resolver = Confined(str(mesh_path))
    resolver.refusals = refusals
    return resolver


MAX_MTL_BYTES = 64 << 20  # a material library is text: a few kB, 64 MiB is far past any real one


def read_asset(path: Path, what: str) -> bytes:
    """The bytes of a file a mesh file names (an OBJ's .mtl or map_Kd image), checked before they are read:
    a regular file; a .mtl at most MAX_MTL_BYTES; an image whose header says it fits the texture limits and
    memory (its bytes and its decoded texels), so that a 3 GB file is refused from its header alone."""
    size = file_size(path, what)
    if path.suffix.lower() == ".mtl":
        if size > MAX_MTL_BYTES:
            raise UsageError(f"{what}: material file of {size} bytes; allowed: at most {MAX_MTL_BYTES >> 20} MiB")
    else:
        width, height = image_header(path, what)
        from .. import memory

        memory.require(size + width * height * memory.TEXEL_BYTES, f"{what}: texture ({width} x {height})")
    with open(path, "rb") as f:
        return f.read()


def regular_file(path, what: str) -> Path:
    """`path`, refused (UsageError naming `what`) unless it is a regular file, symlinks followed: a FIFO, a
    device or a socket would block a read forever or never end, and a folder is not a file.  Checked with
    os.stat, which opens nothing; returns the path."""
    path = Path(path)
    try:
        mode = os.stat(path).st_mode
    except (OSError, ValueError) as exc:  # missing, a broken link, a NUL byte
        reason = "does not exist" if isinstance(exc, FileNotFoundError) else f"cannot be read ({type(exc).__name__})"
        raise UsageError(f"{what}: {shown(str(path))} {reason}") from None
    if not stat.S_ISREG(mode):
        raise UsageError(f"{what}: {shown(str(path))} is not a regular file ({_kind(mode)}); allowed: regular files")
    return path


def _kind(mode: int) -> str:
    kinds = {stat.S_ISFIFO: "a FIFO", stat.S_ISDIR: "a folder", stat.S_ISCHR: "a device", stat.S_ISBLK: "a device", stat.S_ISSOCK: "a socket"}
    return next((name for test, name in kinds.items() if test(mode)), "not a plain file")


def file_size(path, what: str) -> int:
    """The size in bytes of a regular file (regular_file's refusals), read from os.stat before any byte is."""
    return os.stat(regular_file(path, what)).st_size
