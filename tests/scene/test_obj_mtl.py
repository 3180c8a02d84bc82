"""An OBJ's .mtl map_Kd is refused like a glTF texture when it cannot be used (issue 38, defect 8): missing,
outside a confined scene's folder, not an image, past the size limit; and an OBJ with `vt` but no .mtl renders
in the default material, as it does without the `vt` (trimesh's grey placeholder image is not adopted)."""

import struct
import zlib

import numpy as np
import pytest
from PIL import Image

from clrender.errors import UsageError
from clrender.scene.scene import Scene

QUAD = "v -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\n"
FACES_VT = "vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nf 1/1 2/2 3/3\nf 1/1 3/3 4/4\n"


def obj_with_map(folder, map_name: str):
    (folder / "m.mtl").write_text(f"newmtl paint\nKd 1 1 1\nmap_Kd {map_name}\n")
    path = folder / "q.obj"
    path.write_text("mtllib m.mtl\n" + QUAD + "usemtl paint\n" + FACES_VT)
    return path


def png_header(width, height) -> bytes:
    def chunk(kind, body):
        return struct.pack(">I", len(body)) + kind + body + struct.pack(">I", zlib.crc32(kind + body))

    return b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0)) + chunk(b"IDAT", b"")


@pytest.mark.parametrize("allow_outside", [True, False])
def test_missing_map_kd_is_refused(tmp_path, allow_outside):
    with pytest.raises(UsageError, match="map_Kd 'gone.png' does not exist"):
        Scene.from_file(obj_with_map(tmp_path, "gone.png"), allow_outside=allow_outside)


def test_map_kd_outside_a_confined_folder_is_refused(tmp_path):
    Image.new("RGB", (2, 2), (255, 0, 0)).save(tmp_path / "outside.png")
    inner = tmp_path / "inner"
    inner.mkdir()
    with pytest.raises(UsageError, match="outside the scene folder"):
        Scene.from_file(obj_with_map(inner, "../outside.png"), allow_outside=False)


def test_map_kd_that_is_not_an_image_is_refused(tmp_path):
    (tmp_path / "notes.png").write_text("not an image at all\n")
    with pytest.raises(UsageError, match="not an image"):
        Scene.from_file(obj_with_map(tmp_path, "notes.png"))


@pytest.mark.parametrize("width, height", [(16385, 4), (20000, 20000)])  # past our side limit; 20000^2 past Pillow's bomb error too
def test_oversized_map_kd_is_refused_by_our_limit(tmp_path, width, height):
    (tmp_path / "big.png").write_bytes(png_header(width, height))
    with pytest.raises(UsageError, match="texels a side"):
        Scene.from_file(obj_with_map(tmp_path, "big.png"))


def test_a_good_map_kd_is_still_read(tmp_path):
    Image.new("RGB", (2, 1), (255, 0, 0)).save(tmp_path / "red.png")
    scene = Scene.from_file(obj_with_map(tmp_path, "red.png"))
    (texture,) = scene.textures
    np.testing.assert_allclose(texture.pixels[..., :3].reshape(-1, 3), [[1, 0, 0], [1, 0, 0]])


def test_vt_without_material_uses_the_default_material(tmp_path):
    with_vt, without = tmp_path / "vt.obj", tmp_path / "plain.obj"
    with_vt.write_text(QUAD + FACES_VT)
    without.write_text(QUAD + "f 1 2 3\nf 1 3 4\n")
    a, b = Scene.from_file(with_vt), Scene.from_file(without)
    assert a.objects[0].material == b.objects[0].material == "default"
    assert not a.textures and a.materials.keys() == b.materials.keys()
