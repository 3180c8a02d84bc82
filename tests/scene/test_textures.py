"""Textures read (clrender/scene/textures.py, gltf.py): decoding (sRGB or linear by use, channel counts, 16-bit),
packing, glTF images from data URIs, GLB bufferViews and files beside the glTF, OBJ `vt` and .mtl materials
through trimesh, and bad input: a missing, truncated, too large or unsupported image, or an image outside a
confined scene's folder is one line, exit 2, nothing written."""

import base64
import json
import struct

import numpy as np
import pytest
from PIL import Image

from clrender.errors import UsageError
from clrender.scene.scene import Scene
from clrender.scene.textures import decode, pack, srgb_to_linear

from tests.clitools import run_cli
from tests.gltftools import png_bytes, textured_quad

MATERIAL = {"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}, "metallicFactor": 0.0}}


def test_srgb_decode_and_linear_data():
    texels = np.array([[[0, 128, 255, 64]]], np.uint8)
    colour = decode(png_bytes(texels), srgb=True, what="t")
    data = decode(png_bytes(texels), srgb=False, what="t")
    np.testing.assert_allclose(colour[0, 0], [0.0, 0.2158605, 1.0, 64 / 255], rtol=1e-6)  # alpha is never decoded
    np.testing.assert_allclose(data[0, 0], [0.0, 128 / 255, 1.0, 64 / 255], rtol=1e-6)
    assert srgb_to_linear(np.array(0.04045)) == pytest.approx(0.04045 / 12.92)


@pytest.mark.parametrize("channels", [1, 2, 3, 4])
def test_channel_counts(channels):
    texels = np.arange(2 * 3 * channels, dtype=np.uint8).reshape(2, 3, channels) * 10
    out = decode(png_bytes(texels), srgb=False, what="t")
    assert out.shape == (2, 3, 4)
    grey = texels[..., 0] / 255
    if channels <= 2:
        np.testing.assert_allclose(out[..., :3], np.repeat(grey[..., None], 3, -1), rtol=1e-6)
    else:
        np.testing.assert_allclose(out[..., :3], texels[..., :3] / 255, rtol=1e-6)
    alpha = texels[..., -1] / 255 if channels in (2, 4) else np.ones((2, 3))
    np.testing.assert_allclose(out[..., 3], alpha, rtol=1e-6)


def test_sixteen_bit_grey(tmp_path):
    Image.fromarray(np.array([[0, 32768, 65535]], np.uint16)).save(tmp_path / "g.png")
    np.testing.assert_allclose(decode(tmp_path / "g.png", srgb=False, what="g")[0, :, 0], [0, 32768 / 65535, 1], rtol=1e-6)


def test_pack_offsets_and_records():
    from clrender.scene.textures import TextureImage

    a, b = TextureImage(np.ones((2, 3, 4), np.float32)), TextureImage(np.zeros((4, 1, 4), np.float32), "clamp_to_edge", "mirrored_repeat", True)
    records, texels = pack([a, b])
    assert texels.shape == (10, 4)
    assert records["offset"].tolist() == [0, 6] and records["width"].tolist() == [3, 1] and records["height"].tolist() == [2, 4]
    assert records["wrap_s"].tolist() == [10497, 33071] and records["wrap_t"].tolist() == [10497, 33648] and records["nearest"].tolist() == [0, 1]


def test_gltf_texture_sources_agree(tmp_path):
    """The same PNG as a data URI, a file beside the glTF and a GLB bufferView gives the same texels."""
    texels = np.array([[[10, 20, 30], [40, 50, 60]]], np.uint8)
    png = png_bytes(texels)
    (tmp_path / "tex.png").write_bytes(png)
    embedded = Scene.load(str(textured_quad(tmp_path, MATERIAL, [png], name="a.gltf")))
    beside = Scene.load(str(textured_quad(tmp_path, MATERIAL, [{"uri": "tex.png"}], name="b.gltf")))
    # a GLB: the glTF's JSON, its buffer and the PNG in one BIN chunk
    doc = json.loads((tmp_path / "a.gltf").read_text())
    blob = base64.b64decode(doc["buffers"][0]["uri"].split(",", 1)[1])
    blob += b"\0" * (-len(blob) % 4)
    doc["bufferViews"].append({"buffer": 0, "byteOffset": len(blob), "byteLength": len(png)})
    doc["images"] = [{"bufferView": len(doc["bufferViews"]) - 1, "mimeType": "image/png"}]
    blob += png + b"\0" * (-len(png) % 4)
    doc["buffers"] = [{"byteLength": len(blob)}]
    text = json.dumps(doc).encode()
    text += b" " * (-len(text) % 4)
    glb = struct.pack("<4sII", b"glTF", 2, 12 + 8 + len(text) + 8 + len(blob))
    glb += struct.pack("<II", len(text), 0x4E4F534A) + text + struct.pack("<II", len(blob), 0x004E4942) + blob
    (tmp_path / "c.glb").write_bytes(glb)
    binary = Scene.load(str(tmp_path / "c.glb"))
    for scene in (embedded, beside, binary):
        assert len(scene.textures) == 1
        np.testing.assert_array_equal(scene.textures[0].pixels, embedded.textures[0].pixels)
        assert scene.textures[0].nearest
        mesh = scene.objects[0]
        np.testing.assert_allclose(mesh.uvs, [[0, 1], [1, 1], [1, 0], [0, 0]])


def test_texcoord_1_and_transform_reach_the_record(tmp_path):
    info = {"index": 0, "texCoord": 0, "extensions": {"KHR_texture_transform": {"offset": [0.5, 0], "rotation": 0.0, "scale": [2, 3], "texCoord": 1}}}
    path = textured_quad(tmp_path, {"pbrMetallicRoughness": {"baseColorTexture": info}}, [png_bytes(np.zeros((1, 1, 3)))])
    material = Scene.load(str(path)).materials["material_0"]
    record = material.pack()
    assert record["textures"].tolist() == [0, -1, -1, -1, -1]
    assert record["tex_coord"][0] == 1
    np.testing.assert_allclose(record["tex_transform"][0], [2, 0, 0.5, 0, 3, 0])


def test_obj_vt_and_mtl(tmp_path):
    """An OBJ's vt are flipped to glTF's convention and its .mtl becomes a material: Kd, Ks, Ns, 1 - d, Ke, map_Kd."""
    Image.fromarray(np.array([[[255, 0, 0], [0, 128, 0]]], np.uint8)).save(tmp_path / "tex.png")
    (tmp_path / "m.mtl").write_text("newmtl paint\nKd 0.5 0.6 0.7\nKs 0.1 0.2 0.3\nNs 20\nd 0.75\nKe 1 2 3\nmap_Kd tex.png\n")
    (tmp_path / "q.obj").write_text(
        "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nusemtl paint\nf 1/1 2/2 3/3\nf 1/1 3/3 4/4\n"
    )
    scene = Scene.from_dict({"objects": [{"type": "mesh", "file": "q.obj"}]}, base_dir=tmp_path)
    mesh = scene.objects[0]
    np.testing.assert_allclose(mesh.uvs, [[0, 1], [1, 1], [1, 0], [0, 0]])
    m = scene.materials[mesh.material]
    assert m.diffuse == (0.5, 0.6, 0.7) and m.specular == (0.1, 0.2, 0.3) and m.shininess == 20
    assert m.transparency == pytest.approx(0.25) and m.emission == (1, 2, 3)
    np.testing.assert_allclose(scene.textures[m.base_color_texture.index].pixels[0, :, :3], [[1, 0, 0], [0, 0.2158605, 0]], rtol=1e-6)
    named = Scene.from_dict({"objects": [{"type": "mesh", "file": "q.obj", "material": "default"}]}, base_dir=tmp_path)
    assert named.objects[0].material == "default" and not named.textures  # a material named in the scene wins


def scene_with(tmp_path, texture: dict) -> str:
    path = tmp_path / "s.toml"
    body = "".join(f"{k} = {json.dumps(v)}\n" for k, v in texture.items())
    path.write_text(
        f'[textures.t]\n{body}\n[materials.m]\ndiffuse_texture = "t"\n\n'
        '[[objects]]\ntype = "quad"\ncorner = [-1, -1, -3]\nedge_a = [2, 0, 0]\nedge_b = [0, 2, 0]\nmaterial = "m"\n'
        '[[lights]]\ntype = "directional"\ndirection = [0, 0, -1]\n'
    )
    return str(path)


def refused(capsys, tmp_path, scene, *extra):
    out = tmp_path / "out.png"
    code, _, err = run_cli(capsys, "render", scene, "--width", "8", "--height", "8", "-o", str(out), *extra)
    assert code == 2, err
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err
    assert not out.exists()
    return err


def test_a_toml_texture_renders(capsys, tmp_path):
    Image.fromarray(np.full((2, 2, 3), 128, np.uint8)).save(tmp_path / "t.png")
    out = tmp_path / "out.exr"
    code, _, err = run_cli(capsys, "render", scene_with(tmp_path, {"file": "t.png"}), "--width", "8", "--height", "8", "-o", str(out))
    assert code == 0, err


def test_missing_texture(capsys, tmp_path):
    assert "does not exist" in refused(capsys, tmp_path, scene_with(tmp_path, {"file": "nope.png"}))


def test_truncated_texture(capsys, tmp_path):
    png = png_bytes(np.random.default_rng(1).integers(0, 255, (64, 64, 3)))
    (tmp_path / "t.png").write_bytes(png[: len(png) // 2])
    assert "cannot be decoded" in refused(capsys, tmp_path, scene_with(tmp_path, {"file": "t.png"}))


def test_texture_too_large_for_memory(capsys, tmp_path):
    Image.fromarray(np.zeros((2048, 2048, 3), np.uint8)).save(tmp_path / "t.png")
    err = refused(capsys, tmp_path, scene_with(tmp_path, {"file": "t.png"}), "--max-memory", "32M")
    assert "memory" in err and "2048 x 2048" in err


def test_unsupported_channels(capsys, tmp_path):
    Image.fromarray(np.zeros((4, 4, 4), np.uint8), "CMYK").save(tmp_path / "t.jpg")
    assert "CMYK" in refused(capsys, tmp_path, scene_with(tmp_path, {"file": "t.jpg"}))


def test_unknown_texture_name(capsys, tmp_path):
    path = scene_with(tmp_path, {"file": "t.png"}).replace("", "")
    text = open(path).read().replace('diffuse_texture = "t"', 'diffuse_texture = "other"')
    open(path, "w").write(text)
    assert "unknown texture" in refused(capsys, tmp_path, path)


def test_confined_gltf_image_outside_the_folder(tmp_path):
    inner = tmp_path / "inner"
    inner.mkdir()
    (tmp_path / "secret.png").write_bytes(png_bytes(np.zeros((1, 1, 3))))
    path = textured_quad(inner, MATERIAL, [{"uri": "../secret.png"}])
    Scene.from_file(path)  # allowed for local files
    with pytest.raises(UsageError, match="outside the scene folder"):
        Scene.from_file(path, allow_outside=False)


def test_gltf_missing_and_truncated_images(capsys, tmp_path):
    missing = textured_quad(tmp_path, MATERIAL, [{"uri": "gone.png"}], name="m.gltf")
    assert "does not exist" in refused(capsys, tmp_path, str(missing))
    png = png_bytes(np.random.default_rng(2).integers(0, 255, (32, 32, 3)))
    truncated = textured_quad(tmp_path, MATERIAL, [png[:100]], name="t.gltf")
    assert "cannot be decoded" in refused(capsys, tmp_path, str(truncated))


def test_textures_are_counted_together_against_memory(capsys, tmp_path):
    """Two 1024^2 textures of 56 MiB each (memory.TEXEL_BYTES: decoding's peak and the device copy) beside the
    256 MiB base: the first fits 340 MiB (312), the second, counted with it (368), does not."""
    for name in ("a", "b"):
        Image.fromarray(np.zeros((1024, 1024, 3), np.uint8)).save(tmp_path / f"{name}.png")
    path = tmp_path / "two.toml"
    path.write_text(
        '[textures.a]\nfile = "a.png"\n[textures.b]\nfile = "b.png"\n'
        '[materials.m]\nbase_color_texture = "a"\nmetallic_roughness_texture = "b"\n'
        '[[objects]]\ntype = "quad"\ncorner = [-1, -1, -3]\nedge_a = [2, 0, 0]\nedge_b = [0, 2, 0]\nmaterial = "m"\n'
    )
    err = refused(capsys, tmp_path, str(path), "--max-memory", "340M")
    assert "b.png" in err and "and the textures before it" in err and "368 MiB" in err
