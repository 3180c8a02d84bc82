"""Texel values and texture coordinates that would reach the shading as NaN or inf (issue 38, defects 2 and 3).

A float TIFF (Pillow mode "F") or a 32-bit integer one (mode "I") is decoded as it is stored, so its values
are checked after decoding: anything outside [0, 1] (NaN, inf, negative, 2e9) is one line, exit 2, with no
numpy warning on the way.  A glTF TEXCOORD past checks.UV_LIMIT is refused at load, so that a texture
transform's scale (<= 1e6) times it stays inside float32 (3e38 times 2 was NaN in the Whitted lookup)."""

import json
import math
import warnings

import numpy as np
import pytest
from PIL import Image

from clrender.errors import UsageError
from clrender.scene.checks import UV_LIMIT
from clrender.scene.scene import Scene
from clrender.scene.textures import decode

from tests.clitools import run_cli
from tests.gltftools import textured_quad

HOSTILE = [math.nan, math.inf, -math.inf, -0.5, 2e9, 1.0 + 1e-6]


def tiff(tmp_path, values, mode="F", name="t.tiff"):
    """A 2 x 2 single-channel TIFF holding `values` (Pillow writes float and 32-bit integer TIFFs of one channel)."""
    texels = np.array(values, np.float32 if mode == "F" else np.int32).reshape(2, 2)
    path = tmp_path / name
    Image.fromarray(texels, mode=mode).save(path)
    return path


def material_scene(tmp_path, slot: str, file: str) -> str:
    path = tmp_path / "s.toml"
    path.write_text(
        f'[textures.t]\nfile = "{file}"\n[materials.m]\nbase_color = [1, 1, 1]\n{slot} = "t"\n'
        "emission = [1, 1, 1]\n"
        '[[objects]]\ntype = "quad"\ncorner = [-1, -1, -3]\nedge_a = [2, 0, 0]\nedge_b = [0, 2, 0]\nmaterial = "m"\n'
        '[[lights]]\ntype = "directional"\ndirection = [0, 0, -1]\n'
    )
    return str(path)


@pytest.mark.parametrize("value", HOSTILE)
def test_a_float_texel_outside_0_1_is_refused_after_decoding(value):
    """A float TIFF is taken as stored: each hostile value is refused; 0.25 and 1 pass as they are."""
    import io

    buffer = io.BytesIO()
    Image.fromarray(np.array([[0.25, value], [1.0, 0.0]], np.float32), mode="F").save(buffer, format="TIFF")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(UsageError, match=r"allowed: 0 to 1") as info:
            decode(buffer.getvalue(), srgb=False, what="t.tiff")
    assert "\n" not in str(info.value)
    buffer = io.BytesIO()
    Image.fromarray(np.array([[0.25, 1.0], [1.0, 0.0]], np.float32), mode="F").save(buffer, format="TIFF")
    np.testing.assert_array_equal(decode(buffer.getvalue(), srgb=False, what="t")[..., 0], [[0.25, 1.0], [1.0, 0.0]])


@pytest.mark.parametrize("slot", ["base_color_texture", "emissive_texture", "metallic_roughness_texture", "occlusion_texture", "normal_texture"])
@pytest.mark.parametrize("mode,value", [("F", math.nan), ("F", math.inf), ("F", -1.0), ("I", 2_000_000_000), ("I", -5)])
def test_hostile_texels_are_one_line_in_every_slot(capfd, tmp_path, slot, mode, value):
    """The red team's TIFFs (NaN, inf, negative, 2e9) in each slot: exit 2, one line, nothing written, no numpy warning."""
    tiff(tmp_path, [0, value, 0, 0] if mode == "I" else [0.5, value, 0.5, 0.5], mode)
    out = tmp_path / "out.exr"
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        code, _, err = run_cli(capfd, "render", material_scene(tmp_path, slot, "t.tiff"), "--integrator", "path", "--spp", "1",
                               "--width", "8", "--height", "8", "-o", str(out))  # fmt: skip
    assert code == 2, err
    assert len(err.strip().splitlines()) == 1 and "allowed: 0 to 1" in err and "t.tiff" in err
    assert not out.exists()


def test_uvs_past_the_limit_are_refused_at_load(tmp_path):
    """TEXCOORD_0 of 3e38 (finite) under a KHR_texture_transform scale of 2: refused naming the value and the limit;
    UV_LIMIT times the largest scale a texture reference takes (1e6) stays inside float32."""
    assert UV_LIMIT * 1e6 * 2 < np.finfo(np.float32).max
    material = {"pbrMetallicRoughness": {"baseColorTexture": {"index": 0, "extensions": {"KHR_texture_transform": {"scale": [2, 2]}}}}}
    png = {"uri": "t.png"}
    Image.fromarray(np.full((2, 2, 3), 200, np.uint8)).save(tmp_path / "t.png")
    path = textured_quad(tmp_path, material, [png], uv_scale=3e38)
    with pytest.raises(UsageError, match=r"TEXCOORD_0: a coordinate of 3e\+38; allowed: -1e\+06 to 1e\+06"):
        Scene.from_file(path)
    sane = textured_quad(tmp_path, material, [png], uv_scale=1e6, name="sane.gltf")  # at the limit: read
    assert Scene.from_file(sane).textures


def test_uvs_at_the_limit_render_finite_under_a_transform(capfd, tmp_path):
    """UVs of 1e6 under a texture-transform scale of 2, Whitted: every pixel finite (before the bound, 3e38 gave NaN)."""
    material = {"pbrMetallicRoughness": {"baseColorTexture": {"index": 0, "extensions": {"KHR_texture_transform": {"scale": [2, 2]}}}}}
    Image.fromarray(np.full((2, 2, 3), 200, np.uint8)).save(tmp_path / "t.png")
    path = textured_quad(tmp_path, material, [{"uri": "t.png"}], uv_scale=1e6)
    out = tmp_path / "out.exr"
    code, _, err = run_cli(capfd, "render", str(path), "--width", "16", "--height", "16", "-o", str(out))
    assert code == 0, err
    from clrender.image.files import read_image

    assert np.isfinite(read_image(out).pixels).all()


def test_obj_uvs_past_the_limit_are_dropped_like_nan_ones(tmp_path):
    """An OBJ's vt past UV_LIMIT reads as 0, as a NaN vt does (trimesh gives no file position to name)."""
    (tmp_path / "q.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 3e38 0.5\nvt 0.25 nan\nvt 0.5 0.5\nf 1/1 2/2 3/3\n")
    from clrender.scene.scene import load_mesh_file, vertex_attributes

    uvs = vertex_attributes(load_mesh_file(tmp_path / "q.obj", "t"))[0]
    assert np.isfinite(uvs).all() and np.abs(uvs).max() <= 1.0
    assert json.dumps(uvs.tolist())
