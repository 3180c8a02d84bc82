"""Scene files under hostile input: every bad scene is one short UsageError, every good one renders finite.

The first half pins the defects of issue 14 (each failed on the old reader); the second half is a
hypothesis fuzzer that mutates the bundled scenes.  Its examples that once broke something are kept
below as @example lines, so they run in every profile.

Long run (>= 10,000 scene cases):  CLRENDER_FUZZ_EXAMPLES=10000 pytest tests/test_fuzz_scene.py -m slow
(or --hypothesis-profile=long where tests/conftest.py registers it).
"""
from __future__ import annotations

import copy
import math
import os
import re
import time
import tomllib

import numpy as np
import pytest

from clrender.errors import UsageError
from clrender.scene import Scene, bundled_scenes

MAX_MESSAGE = 300  # characters: a message is a line a person reads, not a dump of the value
CONTROL = re.compile(r"[\x00-\x1f\x7f-\x9f]")
TINY = dict(width=8, height=6, aa="none", light_samples=1, max_depth=3)


def usage_error(data, tmp_path=None, **kwargs) -> str:
    """The message of the UsageError Scene.from_dict raises, checked to be one short clean line."""
    with pytest.raises(UsageError) as err:
        Scene.from_dict(data, base_dir=tmp_path or ".", where="s.toml", **kwargs)
    message = str(err.value)
    assert "\n" not in message and not CONTROL.search(message), repr(message)
    assert len(message) <= MAX_MESSAGE, len(message)
    assert message.startswith("s.toml: "), message
    return message


def render_tiny(scene: Scene) -> np.ndarray:
    from clrender.renderer import render

    return render(scene, **TINY)


def sphere_scene(**sphere) -> dict:
    obj = {"type": "sphere", "center": [0, 0, -3], "radius": 1, **sphere}
    return {"objects": [obj], "lights": [{"type": "point", "position": [2, 2, 0]}]}


# ------------------------------------------------------------------ issue 14's reproducers
def test_background_nested_500_deep_in_a_file_is_one_line(tmp_path):
    path = tmp_path / "deep.toml"
    path.write_text("background = " + "[" * 500 + "]" * 500 + "\n")
    with pytest.raises(UsageError) as err:
        Scene.from_file(path)
    message = str(err.value)
    assert "\n" not in message and len(message) <= MAX_MESSAGE and str(path) in message


def test_background_nested_500_deep_in_a_dict_names_the_key():
    value = []
    for _ in range(500):
        value = [value]
    assert "background" in usage_error({"background": value})


def test_material_that_is_a_list_is_refused():
    message = usage_error(sphere_scene(material=[1]))
    assert "objects[0].material" in message and "name" in message


@pytest.mark.parametrize("seed", [-1, 1.5, 2**32, "7", True])
def test_dense_generator_seed_must_be_a_whole_number_in_range(seed):
    message = usage_error({"objects": [{"type": "mesh", "generator": "dense", "params": {"n_triangles": 64, "seed": seed}}]})
    assert "objects[0].params.seed" in message and "0 to 4294967295" in message


def test_generator_range_errors_name_the_file_and_key():
    message = usage_error({"objects": [{"type": "mesh", "generator": "bunny", "params": {"resolution": 3}}]})
    assert "objects[0].params.resolution" in message and "16 to" in message


@pytest.mark.parametrize("gen, params", [
    ("bunny", {"resolution": 256}),  # did not finish in 120 s
    ("cat", {"resolution": 10_000}),
    ("dense", {"n_triangles": 50_000_000}),  # about 24 GiB
    ("wizard_hat", {"segments": 10**9}),
    ("tower", {"segments": 10**9}),
])
def test_generator_sizes_are_bounded(gen, params):
    (key,) = params
    assert f"objects[0].params.{key}" in usage_error({"objects": [{"type": "mesh", "generator": gen, "params": params}]})


@pytest.mark.parametrize("scale", [1e-40, [1, 1e-40, 1], 1e300, 0])
def test_mesh_scale_out_of_range_is_refused_before_the_bvh(scale):
    assert "objects[0].scale" in usage_error({"objects": [{"type": "mesh", "generator": "wizard_hat", "scale": scale}]})


def test_area_light_samples_are_bounded_like_the_cli():
    light = {"type": "area", "corner": [0, 3, -3], "edge_a": [1, 0, 0], "edge_b": [0, 0, 1], "samples": 100_000}
    message = usage_error({"lights": [light]})
    assert "lights[0].samples" in message and "64" in message


@pytest.mark.parametrize("data, key", [
    ({"ambient": [1e39, 0, 0]}, "ambient"),
    ({"background": [0, 1e300, 0]}, "background"),
    ({"materials": {"m": {"diffuse": [1e300, 0, 0]}}}, "materials.m.diffuse"),
    ({"materials": {"m": {"specular": [0, 0, 3.5e38]}}}, "materials.m.specular"),
    ({"lights": [{"type": "point", "position": [0, 1, 0], "intensity": 1e39}]}, "lights[0].intensity"),
    ({"lights": [{"type": "point", "position": [0, 1, 0], "color": [1e300, 1, 1]}]}, "lights[0].color"),
    ({"lights": [{"type": "point", "position": [4e38, 1, 0]}]}, "lights[0].position"),
    ({"cameras": [{"position": [0, 0, 1e39]}]}, "cameras[0].position"),
    ({"objects": [{"type": "sphere", "center": [0, 0, -3.5e38], "radius": 1}]}, "objects[0].center"),
    ({"objects": [{"type": "sphere", "center": [0, 0, 0], "radius": 1e-300}]}, "objects[0].radius"),
    ({"objects": [{"type": "sphere", "center": [0, 0, -3], "radius": 1e39}]}, "objects[0].radius"),
    ({"objects": [{"type": "triangle", "vertices": [[0, 0, 0], [1, 0, 0], [0, 1e39, 0]]}]}, "objects[0].vertices[2]"),
    ({"objects": [{"type": "mesh", "generator": "tower", "translate": [1e39, 0, 0]}]}, "objects[0].translate"),
    ({"width": 10**400}, "width"),
])
def test_values_beyond_float32_name_the_file_and_key(data, key):
    assert f"s.toml: {key}" in usage_error(data)


def test_a_tiny_sphere_at_the_eye_is_refused_or_renders_finite():
    # radius 1e-300 is 0 in float32: the kernel divided 0 by 0 for the normal
    usage_error(sphere_scene(center=[0, 0, 0], radius=1e-300))
    image = render_tiny(Scene.from_dict(sphere_scene(center=[0, 0, 0], radius=1e-6)))
    assert np.isfinite(image).all()


def test_bright_but_allowed_values_render_finite():
    data = sphere_scene(material="hot")
    data.update(ambient=[1e6] * 3, background=[1e6] * 3, materials={"hot": {"diffuse": [1e6] * 3, "specular": [1e6] * 3}})
    data["lights"] = [{"type": "point", "position": [2, 2, 0], "intensity": 1e6, "color": [1e6] * 3, "falloff": "inverse_square"}]
    image = render_tiny(Scene.from_dict(data))
    assert np.isfinite(image).all() and image.max() > 1e6


def test_a_key_with_a_newline_and_escape_is_shown_escaped():
    message = usage_error({"objects": [{"type": "sphere", "center": [0, 0, 0], "radius": 1, "evil\n\x1b[31mkey": 1}]})
    assert "\\n" in message and "\\x1b" in message


def test_long_bad_values_are_cut():
    message = usage_error({"background": "x" * 5000})
    assert "..." in message or "\u2026" in message


@pytest.mark.parametrize("data", [{1: 2}, {"objects": [{"type": "sphere", "center": [0, 0, 0], "radius": 1, 3: 4}]},
                                  {"materials": {"m": {(1, 2): 1}}}])
def test_non_string_keys_are_refused(data):
    usage_error(data)


@pytest.mark.parametrize("key, n", [("cameras", 65), ("lights", 65)])
def test_counts_are_bounded(key, n):
    item = {"cameras": {}, "lights": {"type": "directional", "direction": [0, -1, 0]}}[key]
    assert key in usage_error({key: [item] * n})


def test_many_objects_are_refused_before_they_are_built():
    start = time.perf_counter()
    usage_error({"objects": [{"type": "sphere", "center": [0, 0, 0], "radius": 1}] * 2_000_000})
    assert time.perf_counter() - start < 5


# ------------------------------------------------------------------ mesh paths
def test_mesh_paths_may_leave_the_base_dir_unless_confined(tmp_path):
    (tmp_path / "tri.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    inner = tmp_path / "scenes"
    inner.mkdir()
    climbing = {"objects": [{"type": "mesh", "file": "../tri.obj"}]}
    absolute = {"objects": [{"type": "mesh", "file": str(tmp_path / "tri.obj")}]}
    for data in (climbing, absolute):
        assert len(Scene.from_dict(data, base_dir=inner).objects[0].faces) == 1  # local files: allowed
        message = usage_error(data, inner, allow_outside=False)
        assert "objects[0].file" in message and "outside" in message
    (inner / "tri.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    inside = {"objects": [{"type": "mesh", "file": "./tri.obj"}]}
    assert len(Scene.from_dict(inside, base_dir=inner, allow_outside=False).objects) == 1


def test_a_symlink_out_of_the_base_dir_is_outside(tmp_path):
    (tmp_path / "tri.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    inner = tmp_path / "scenes"
    inner.mkdir()
    (inner / "link.obj").symlink_to(tmp_path / "tri.obj")
    usage_error({"objects": [{"type": "mesh", "file": "link.obj"}]}, inner, allow_outside=False)
