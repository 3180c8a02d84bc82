"""Textures, environment maps and material values under hostile input (issue 38): every example is refused
with one short line (a UsageError) or renders every pixel finite, in the Whitted and the path integrators.

The strategies write tiny images into the fuzz folder: 8- and 16-bit PNGs, float ("F") and 32-bit integer
("I") TIFFs whose texels are drawn from NaN, +-inf, negatives, 2e9 and values at 0 and 1; EXR environment
maps of the same values; and materials whose reflectances, factors, emission, alpha, double_sided and texture
transforms sit at, just over and far over their limits (docs/scene-format.md, "Limits").  Half the examples
draw only allowed values, so that they get as far as rendering.

Long run:  pytest tests/scene/test_fuzz_textures.py --hypothesis-profile=long
"""

from __future__ import annotations

import itertools
import math
import os
import re
import warnings

import numpy as np
import pytest

from clrender.errors import UsageError
from clrender.scene.scene import Scene

hypothesis = pytest.importorskip("hypothesis")
from hypothesis import HealthCheck, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

MAX_MESSAGE = 400  # a file's path is part of a texture's message: one line, not a dump
CONTROL = re.compile(r"[\x00-\x1f\x7f-\x9f]")
HOSTILE_FLOATS = [math.nan, math.inf, -math.inf, -1.0, -1e-30, 0.0, 1e-40, 0.5, 1.0, 1.0 + 1e-6, 2.0, 65535.0, 2e9, 3e38]
HOSTILE_INTS = [-(2**31), -5, 0, 1, 255, 65535, 65536, 2_000_000_000]
AT_LIMITS = [0.0, -0.0, 1e-6, 0.5, 1.0, 1.0 + 1e-6, 1.5, 2.0, 5.0, 1e6, 1e6 + 1, -1e-6, -1.0]
ALLOWED_FLOATS = [0.0, 1e-40, 1e-6, 0.5, 1.0]  # an "allowed only" example's texels and reflectances: it should render
ALLOWED_RADIANCE = [0.0, 1e-6, 0.5, 1.0, 1e6]
SLOTS_GLTF = ("base_color_texture", "metallic_roughness_texture", "emissive_texture", "occlusion_texture", "normal_texture")
NAMES = itertools.count()


@st.composite
def texture_files(draw, folder, hostile=True):
    """The name of a tiny image written into `folder`: PNG 8/16-bit, or a float or 32-bit integer TIFF."""
    kind = draw(st.sampled_from(["png8", "png16", "tiff_f", "tiff_i"] if hostile else ["png8", "png16", "tiff_f"]))
    h, w = draw(st.integers(1, 3)), draw(st.integers(1, 3))
    from PIL import Image

    if kind == "tiff_f":
        pool = HOSTILE_FLOATS if hostile else ALLOWED_FLOATS
        texels = np.array(draw(st.lists(st.sampled_from(pool), min_size=h * w, max_size=h * w)), np.float32)
        image = Image.fromarray(texels.reshape(h, w), mode="F")
    elif kind == "tiff_i":
        texels = np.array(draw(st.lists(st.sampled_from(HOSTILE_INTS), min_size=h * w, max_size=h * w)), np.int32)
        image = Image.fromarray(texels.reshape(h, w), mode="I")
    elif kind == "png16":
        texels = np.array(draw(st.lists(st.integers(0, 65535), min_size=h * w, max_size=h * w)), np.uint16)
        image = Image.fromarray(texels.reshape(h, w))
    else:
        channels = draw(st.sampled_from([1, 2, 3, 4]))
        texels = np.array(draw(st.lists(st.integers(0, 255), min_size=h * w * channels, max_size=h * w * channels)), np.uint8)
        image = Image.fromarray(texels.reshape(h, w, channels) if channels > 1 else texels.reshape(h, w))
    name = f"tex{next(NAMES)}.{'tiff' if kind.startswith('tiff') else 'png'}"
    image.save(folder / name)
    return name


@st.composite
def environment_tables(draw, folder, hostile=True):
    """None, a constant colour, or an EXR map of hostile radiance with an intensity and rotation at the limits."""
    kind = draw(st.sampled_from(["none", "colour", "map"]))
    if kind == "none":
        return None
    if kind == "colour":
        return {"color": [draw(st.sampled_from(AT_LIMITS if hostile else ALLOWED_RADIANCE)) for _ in range(3)]}
    import OpenImageIO as oiio

    h, w = draw(st.integers(1, 4)), draw(st.integers(1, 4))
    pool = HOSTILE_FLOATS + [1e6, 2e6] if hostile else ALLOWED_RADIANCE
    values = draw(st.lists(st.sampled_from(pool), min_size=h * w * 3, max_size=h * w * 3))
    pixels = np.ascontiguousarray(np.array(values, np.float32).reshape(h, w, 3))
    name = f"env{next(NAMES)}.exr"
    out = oiio.ImageOutput.create(str(folder / name))
    assert out.open(str(folder / name), oiio.ImageSpec(w, h, 3, "float"))
    assert out.write_image(pixels)
    out.close()
    table = {"file": name}
    if draw(st.booleans()):
        table["intensity"] = draw(st.sampled_from(AT_LIMITS if hostile else ALLOWED_RADIANCE))
    if draw(st.booleans()):
        table["rotation"] = draw(st.sampled_from([0.0, 45.0, 360.0, -360.0] + [361.0] * hostile))
    return table


@st.composite
def texture_refs(draw, name, hostile=True):
    if draw(st.booleans()) or not hostile:
        return name
    ref = {"texture": name}
    if draw(st.booleans()):
        ref["scale"] = [draw(st.sampled_from([1.0, 2.0, -1.0, 1e6, 1e6 + 1, 0.0])) for _ in range(2)]
    if draw(st.booleans()):
        ref["offset"] = [draw(st.sampled_from([0.0, 0.5, 1e6, -1e6, 2e6])) for _ in range(2)]
    if draw(st.booleans()):
        ref["rotation"] = draw(st.sampled_from([0.0, 1.0, 1e6, 2e6]))
    if draw(st.booleans()):
        ref["strength"] = draw(st.sampled_from([0.0, 0.5, 1.0, 2.0, -1.0]))
    return ref


@st.composite
def textured_scenes(draw, folder):
    """(scene dict, integrator, max depth): a quad and a sphere in one material with textures and values at the limits."""
    phong_model = draw(st.booleans())
    hostile = draw(st.booleans())  # False: every value allowed, so the example gets as far as rendering
    material = {}
    textures = {}
    slots = ("diffuse_texture", "emissive_texture") if phong_model else SLOTS_GLTF
    for slot in draw(st.lists(st.sampled_from(slots), max_size=3, unique=True)):
        name = f"t{len(textures)}"
        textures[name] = {"file": draw(texture_files(folder, hostile))}
        if draw(st.booleans()):
            textures[name]["filter"] = "nearest"
        material[slot] = draw(texture_refs(name, hostile))
    pool = AT_LIMITS if hostile else ALLOWED_FLOATS
    colour = lambda: [draw(st.sampled_from(pool)) for _ in range(3)]  # noqa: E731
    if phong_model:
        material.update(diffuse=colour(), specular=colour(), mirror=draw(st.sampled_from(pool)))
    else:
        material["base_color"] = colour()
        for key in ("metallic", "roughness", "transmission"):
            if draw(st.booleans()):
                material[key] = draw(st.sampled_from(pool))
    if draw(st.booleans()):
        material["emission"] = [draw(st.sampled_from(AT_LIMITS if hostile else ALLOWED_RADIANCE)) for _ in range(3)]
    if draw(st.booleans()):  # coverage, times the colour texture's alpha
        alpha = {"mode": draw(st.sampled_from(["opaque", "mask", "blend"] + ["dither"] * hostile))}
        for key in ("cutoff", "factor"):
            if draw(st.booleans()):
                alpha[key] = draw(st.sampled_from(pool))
        material["alpha"] = alpha
    if draw(st.booleans()):
        material["double_sided"] = draw(st.sampled_from([True, False] + ["no"] * hostile))
    if draw(st.booleans()):
        material["ior"] = draw(st.sampled_from([0.01, 1.0, 1.5, 100.0] + [1e-3, 101.0] * hostile))
    data = {
        "cameras": [{"position": [0, 0, 0], "look_at": [0, 0, -1], "fov": 60}],
        "materials": {"m": material},
        "textures": textures,
        "objects": [
            {"type": "quad", "corner": [-1, -1, -3], "edge_a": [2, 0, 0], "edge_b": [0, 2, 0], "material": "m"},
            {"type": "sphere", "center": [0.5, 0.5, -2.5], "radius": 0.4, "material": "m"},
        ],
        "lights": [{"type": "point", "position": [0, 1, 0], "intensity": draw(st.sampled_from([1.0, 1e6]))}],
    }
    environment = draw(environment_tables(folder, hostile))
    if environment is not None:
        data["environment"] = environment
    integrator = draw(st.sampled_from(["whitted", "path"]))
    return data, integrator, draw(st.sampled_from([1, 3, 16] if integrator == "whitted" else [1, 3, 64, 1024]))


@pytest.fixture(scope="module")
def texture_dir(tmp_path_factory):
    return tmp_path_factory.mktemp("fuzz_textures")


FUZZ_EXAMPLES = os.environ.get("CLRENDER_FUZZ_EXAMPLES")
FUZZ = settings(deadline=None, suppress_health_check=list(HealthCheck), **({"max_examples": int(FUZZ_EXAMPLES)} if FUZZ_EXAMPLES else {}))
STATS = {"cases": 0, "refused": 0, "rendered": 0}


def check(data, integrator: str, max_depth: int, folder) -> None:
    """The property: one short clean UsageError line and no warning, or a tiny render with every pixel finite."""
    import clrender

    STATS["cases"] += 1
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)  # a numpy warning would print raw lines on the terminal
        try:
            scene = Scene.from_dict(data, base_dir=folder, where="fuzz.toml")
        except UsageError as exc:
            STATS["refused"] += 1
            message = str(exc)
            assert "\n" not in message and not CONTROL.search(message), repr(message)
            assert len(message) <= MAX_MESSAGE, message
            return
        image = clrender.Renderer(scene, integrator=integrator, samples=1, width=8, height=6, max_depth=max_depth).run().image
    STATS["rendered"] += 1
    assert image.shape == (6, 8, 3) and np.isfinite(image).all(), data


@pytest.mark.slow  # renders both integrators per example: 84 s under the ci profile with a cold kernel cache
@FUZZ
@given(data=st.data())
def test_textured_scenes_are_refused_cleanly_or_render_finite(data, texture_dir):
    scene, integrator, depth = data.draw(textured_scenes(texture_dir))
    check(scene, integrator, depth, texture_dir)


def test_texture_fuzz_counts_report():
    """How many cases ran, and that some of each outcome did (run with -s to see it)."""
    print(f"\ntexture fuzz: {STATS}")
    assert STATS["cases"] == 0 or STATS["refused"] + STATS["rendered"] == STATS["cases"]
