"""Mesh files read by trimesh (and PLY triangle strips, which it does not read), checked once for every reader:
TOML and bare-mesh scenes (scene.py), pbrt-v4's `plymesh` (pbrt_shapes.py) and Mitsuba's `obj`/`ply`
(mitsuba_shapes.py)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import UsageError
from . import obj_mtl


def load_mesh_file(path: Path, what: str, root=None):
    """A trimesh.Trimesh from any format trimesh reads, checked for emptiness, NaNs and face indices."""
    import trimesh

    from ..errors import MAX_SHOWN, first_line, one_line, shown

    if not path.is_file():
        raise UsageError(f"{what}: mesh file {str(path)!r} does not exist")
    maps = obj_mtl.mtl_maps(path, root, what)  # an OBJ's map_Kd files checked before trimesh reads them
    try:
        from .confine import trimesh_resolver
        from .ply_strips import read_tristrips  # triangle strips, which trimesh does not read

        # a mesh reads its materials and images through confine.py too: regular files of a bounded size, and
        # in a confined scene only inside its folder
        resolver = trimesh_resolver(path, root)
        tm = read_tristrips(path) if path.suffix.lower() == ".ply" else None
        if tm is None:
            tm = trimesh.load(str(path), force="mesh", process=False, resolver=resolver)
        if resolver.refusals:  # trimesh drops an asset its resolver refused; the refusal still stands
            raise resolver.refusals[0]
    except UsageError:
        raise
    except Exception as exc:  # trimesh raises many kinds for malformed files
        # On undecodable text trimesh reaches for an optional encoding guesser (charset_normalizer):
        # the missing module is trimesh's detail, the file is the user's problem.
        kind = one_line(path.suffix.lstrip(".").upper() or "a mesh", 20)
        if isinstance(exc, ImportError) and exc.name == "charset_normalizer":
            reason = "not text in a known encoding"
        elif isinstance(exc, ImportError):
            reason = f"reading {kind} needs the Python module {exc.name}, which is not installed"
        else:
            reason = first_line(str(exc)) or type(exc).__name__
        raise UsageError(f"{what}: cannot parse mesh {shown(path)} as {kind} ({one_line(reason, MAX_SHOWN)})") from None
    if not isinstance(tm, trimesh.Trimesh) or len(tm.faces) == 0:
        raise UsageError(f"{what}: mesh {str(path)!r} has no triangles")
    faces = np.asarray(tm.faces)
    if not 0 <= faces.min() <= faces.max() < len(tm.vertices):  # numpy would wrap -1 silently, or raise IndexError
        bad = faces.min() if faces.min() < 0 else faces.max()
        raise UsageError(f"{what}: mesh {shown(path)} has face index {bad}; allowed: 0 to {len(tm.vertices) - 1} (its vertices)")
    if not np.isfinite(tm.vertices).all():
        raise UsageError(f"{what}: mesh {str(path)!r} has NaN or infinite vertices")
    if path.suffix.lower() == ".obj":
        tm.metadata[obj_mtl.METADATA_KEY] = maps  # None: no .mtl, so no material (textures.mtl_material)
    return tm
