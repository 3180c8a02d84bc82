"""An OBJ's `.mtl` texture maps, found and checked by clrender rather than trimesh (which drops a map_Kd it
cannot read without a word, and gives an OBJ with `vt` but no material a grey placeholder image).

trimesh reads the first `mtllib` line of the OBJ (its rule, kept here) and each material's `map_Kd` as the rest
of the line.  Every map_Kd of that .mtl is resolved here through confine.scene_file (a confined scene refuses a
path outside its folder) and must be an existing regular file; textures.decode then refuses what is not an
image or past the size limits.  An OBJ without an mtllib brings no material: it renders in the default one,
whether it has `vt` or not (docs/materials.md#obj-and-mtl).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from ..errors import UsageError, shown
from .confine import read_asset, regular_file, scene_file
from .image_files import image_header

METADATA_KEY = "clrender_mtl_maps"  # where load_mesh_file leaves mtl_maps' answer on the trimesh mesh
CHUNK = 1 << 20  # the OBJ is scanned for "mtllib" in pieces of this many bytes (it may be large)


@dataclass(frozen=True)
class MtlMaps:
    maps: dict  # newmtl name -> the resolved path of its map_Kd


def _first_mtllib(obj_path: Path) -> str | None:
    """The name on the OBJ's first `mtllib` line (trimesh reads that one), else None."""
    tail = b""
    with open(obj_path, "rb") as f:
        while chunk := f.read(CHUNK):
            text = tail + chunk
            at = text.find(b"mtllib")
            if at >= 0:
                line = text[at:] + (b"" if b"\n" in text[at:] else f.read(4096))
                name = line.split(b"\n", 1)[0][len(b"mtllib") :].strip()
                return name.decode("utf-8", "replace") or None
            tail = text[-8:]
    return None


def mtl_maps(obj_path: Path, root, what: str) -> MtlMaps | None:
    """The map_Kd files of an OBJ's .mtl, each checked (UsageError naming it otherwise); None when the OBJ names
    no mtllib or its .mtl cannot be read (trimesh then brings no material either)."""
    obj_path = Path(obj_path)
    if obj_path.suffix.lower() != ".obj":
        return None
    name = _first_mtllib(obj_path)
    if name is None:
        return None
    mtl = scene_file(obj_path.parent, name, root, f"{what}: mtllib")
    if not mtl.exists():
        return None
    maps, material = {}, None
    for line in read_asset(mtl, f"{what}: mtllib {shown(name)}").decode("utf-8", "replace").splitlines():
        split = line.strip().split()
        if len(split) <= 1:
            continue
        key = split[0].lower()
        if key == "newmtl":
            material = " ".join(split[1:])
        elif key == "map_kd" and material is not None:
            file_name = line[line.lower().index("map_kd") + 6 :].strip()
            path = scene_file(mtl.parent, file_name, root, f"{what}: {name} map_Kd")
            if not path.exists():
                raise UsageError(f"{what}: {name}: map_Kd {shown(file_name)} does not exist; allowed: an image file")
            image_header(regular_file(path, f"{what}: {name} map_Kd {shown(file_name)}"), f"{what}: {name} map_Kd {shown(file_name)}")
            maps[material] = path
    return MtlMaps(maps)
