"""Material values and the path tracer's throughput (issue 38, defect 1).

Reflectances (`base_color`, `diffuse`, `specular`) are glTF's [0, 1]: above 1 a lobe returns more light than
it receives, and the throughput of a path grew past float32 (base colour 1e6: every pixel NaN; 5 at
--max-depth 64).  They are refused above 1 (one line, exit 2), an OBJ's Kd / Ks is clamped to 1 with a
warning, and kernels/path.cl ends a path whose throughput passes BETA_LIMIT, so that no setting gives a
NaN or inf pixel even when a Scene is built past the readers."""

import dataclasses
import json

import numpy as np
import pytest

import clrender
from clrender.errors import RenderWarning, UsageError
from clrender.scene.scene import Scene

from tests.clitools import run_cli
from tests.gltftools import CAMERA, CAMERA_NODE, LIGHT, LIGHT_NODE, gltf_file

BOX = {
    "cameras": [{"position": [0, 0, 0], "look_at": [0, 0, -1], "fov": 60}],
    "environment": {"color": [1, 1, 1]},
    "objects": [{"type": "sphere", "center": [0, 0, -3], "radius": 1, "material": "m"}],
}


def scene_dict(material: dict) -> dict:
    return {**BOX, "materials": {"m": material}}


@pytest.mark.parametrize("key", ["base_color", "diffuse", "specular"])
@pytest.mark.parametrize("value", [1.0 + 1e-6, 2.0, 5.0, 1e6])
def test_a_reflectance_above_one_is_refused(key, value):
    with pytest.raises(UsageError, match=rf"materials\.m\.{key}: .* is out of range; allowed: 0 to 1 per channel"):
        Scene.from_dict(scene_dict({key: [0.5, value, 0.5]}))
    assert Scene.from_dict(scene_dict({key: [1, 1, 1]})).materials["m"]  # 1 itself is read


def test_emission_stays_unbounded_to_the_radiance_limit():
    """Emission is radiance, not a reflectance: up to checks.RADIANCE_LIMIT (1e6), finite."""
    assert Scene.from_dict(scene_dict({"base_color": [1, 1, 1], "emission": [1e6, 1e6, 1e6]})).materials["m"].emission == (1e6,) * 3
    with pytest.raises(UsageError, match="allowed: 0 to 1e\\+06"):
        Scene.from_dict(scene_dict({"base_color": [1, 1, 1], "emission": [2e6, 0, 0]}))


def test_a_gltf_base_colour_factor_above_one_is_refused(capsys, tmp_path):
    """The red team's 1e6 baseColorFactor: one line, exit 2, nothing written (glTF's range is [0, 1])."""
    material = {"pbrMetallicRoughness": {"baseColorFactor": [1e6, 1e6, 1e6, 1]}}
    path = gltf_file(tmp_path, [{"mesh": 0}, CAMERA_NODE, LIGHT_NODE], cameras=[CAMERA], lights=[LIGHT], materials=[material])
    out = tmp_path / "out.exr"
    code, _, err = run_cli(capsys, "render", str(path), "--integrator", "path", "--width", "8", "--height", "8", "-o", str(out))
    assert code == 2 and len(err.strip().splitlines()) == 1 and "base_color" in err and "allowed: 0 to 1" in err, err
    assert not out.exists()
    assert json.loads(path.read_text())  # the file itself is fine JSON: the value is what is refused


def test_an_obj_kd_above_one_is_clamped_with_a_warning(tmp_path):
    (tmp_path / "q.obj").write_text("mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl a\nf 1 2 3\n")
    (tmp_path / "m.mtl").write_text("newmtl a\nKd 5 0.5 0.5\nKs 0.1 0.1 0.1\n")
    with pytest.warns(RenderWarning, match=r"Kd 5 clamped to 1"):
        scene = Scene.from_file(tmp_path / "q.obj")
    material = next(m for name, m in scene.materials.items() if name.startswith("q.obj"))
    assert material.diffuse == (1.0, 0.5, 0.5)


def test_no_throughput_gives_a_nan_pixel():
    """A Scene whose material is made past the reader (base colour 1e6, the red team's value) at --max-depth 64:
    every pixel finite (before the BETA_LIMIT guard, NaN).  The camera sits inside a glowing rough sphere, so
    every path keeps bouncing and its throughput grows by 1e6 a bounce."""
    data = {
        "cameras": [{"position": [0, 0, 0], "look_at": [0, 0, -1], "fov": 60}],
        "materials": {"m": {"base_color": [1, 1, 1], "roughness": 1.0, "emission": [1, 1, 1]}},
        "objects": [{"type": "sphere", "center": [0, 0, 0], "radius": 5, "material": "m"}],
    }
    scene = Scene.from_dict(data)
    scene.materials["m"] = dataclasses.replace(scene.materials["m"], base_color=(1e6, 1e6, 1e6))
    image = clrender.Renderer(scene, integrator="path", samples=2, width=8, height=8, max_depth=64).run().image
    assert np.isfinite(image).all()
