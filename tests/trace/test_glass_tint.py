"""Coloured glTF glass (KHR_materials_transmission: the BTDF times base_color, reflection untinted; docs/materials.md).

Fast: a smooth pane seen head-on by an orthographic camera against a constant white environment, where every path
ends in the environment: it reflects at the front face (probability F, value 1) or enters and leaves (two
transmissions, value t^2 per channel, however often it reflects inside), so a pixel's expected value is
F + (1 - F) t^2 with F = ((n - 1) / (n + 1))^2 at normal incidence (the depth limit, deep inside, cuts ~F^6); a
pooled z-test per channel at ALPHA.  Russian roulette is off there (rr_depth past max_depth): its rare kills of the
few paths that reflect inside three times would dominate a channel's variance once the sampler stratifies the
reflect-or-transmit choice, and pixel means of rare +-jumps are far from normal; every channel's t is below 1, so
each has a variance to test against.  Rough:
a single rough-glass card with no bounce after the first (max_depth 0) sends each path once, reflected (untinted)
or transmitted (times t), with the same random numbers in every channel, so with t = (1, 0.3, 0) green is
blue + 0.3 (red - blue) path by path, and red - blue (the transmitted light) is most of the image.
Slow: a smooth tinted sphere against Mitsuba's `dielectric` with `specular_transmittance` (block z-test).
"""

from statistics import NormalDist

import numpy as np
import pytest

from clrender.scene.scene import Scene
from clrender.trace.renderer import Renderer
from clrender.trace.tracer import Tracer

from tests.reference import path_scenes
from tests.reference.path_scenes import quad
from tests.reference.ztest import sidak

ALPHA = 1e-3  # false-alarm probability of each statistical test function
IOR = 1.5


def glass(base, roughness=0.0) -> dict:
    return {"base_color": list(base), "metallic": 0.0, "roughness": roughness, "transmission": 1.0, "ior": IOR}


def ortho_scene(objects, materials, size=16) -> dict:
    cam = {"position": [0, 0, 3], "look_at": [0, 0, 0], "up": [0, 1, 0], "projection": "orthographic", "ortho_height": 1.0}
    return {"width": size, "height": size, "cameras": [cam], "environment": {"color": [1, 1, 1]}, "materials": materials, "objects": objects}


def render(scene, device, **kw):
    loaded = Scene.from_dict(scene)
    return Renderer(loaded, tracer=Tracer(loaded, device=device), integrator="path", **kw).run().image.astype(np.float64)


def test_a_tinted_smooth_pane_transmits_base_colour_squared_and_reflects_white(device):
    tint = np.array([0.9, 0.5, 0.2])
    vertices, faces = path_scenes.box_mesh([0, 0, 0], [4, 4, 0.2])
    scene = ortho_scene([path_scenes.mesh(vertices, faces, "glass")], {"glass": glass(tint)})
    img = render(scene, device, spp=64, max_depth=8, seed=1, rr_depth=9)
    f = ((IOR - 1) / (IOR + 1)) ** 2
    expected = f + (1 - f) * tint**2  # white (1, 1, 1) before the old code's fix: every channel 1
    pixels = img.reshape(-1, 3)
    z = (pixels.mean(axis=0) - expected) / (pixels.std(axis=0, ddof=1) / np.sqrt(len(pixels)))
    limit = NormalDist().inv_cdf(1 - sidak(ALPHA, 3) / 2)
    assert np.all(np.abs(z) < limit), f"means {pixels.mean(axis=0)} vs {expected}: z {z}"


def test_a_tinted_rough_card_tints_only_what_it_transmits(device):
    materials = {"glass": glass((1.0, 0.3, 0.0), roughness=0.4)}
    scene = ortho_scene([quad([-2, -2, 0], [4, 0, 0], [0, 4, 0], "glass")], materials)
    img = render(scene, device, spp=16, max_depth=0, seed=2)
    red, green, blue = img[..., 0], img[..., 1], img[..., 2]
    np.testing.assert_allclose(green, blue + 0.3 * (red - blue), atol=1e-5)
    assert (red - blue).mean() > 0.3  # most light goes through, times 1/ior^2 (an untinted card: red == blue)
    assert 0.0 < blue.mean() < 0.2  # and some is reflected, white


@pytest.mark.slow
def test_tinted_glass_matches_mitsubas_dielectric_with_specular_transmittance(device):
    """A smooth sphere of base colour (1, 0.3, 0.3) over a diffuse floor in a constant environment, and a white one
    beside it: Mitsuba's `dielectric` with `specular_transmittance` (tests/reference/mitsuba_scenes.py), 64 x 64,
    K = 4 renders of 64 spp a side, max_depth 6, the block z-test at alpha 0.01."""
    from tests.mitsubatools import K, clrender_path_renders, mitsuba_or_skip, mitsuba_renders
    from tests.reference.ztest import two_sample_z

    mitsuba_or_skip("llvm_ad_rgb")
    scene = path_scenes.scene(
        64,
        path_scenes.camera([0, 1.2, 4.0], [0, 0.5, 0], 35),
        {"floor": {"diffuse": [0.7, 0.7, 0.7]}, "red": glass((1.0, 0.3, 0.3)), "white": glass((1.0, 1.0, 1.0))},
        [
            quad([-4, 0, 4], [8, 0, 0], [0, 0, -8], "floor"),
            {"type": "sphere", "center": [-0.6, 0.6, 0], "radius": 0.6, "material": "red"},
            {"type": "sphere", "center": [0.7, 0.5, 0.3], "radius": 0.5, "material": "white"},
        ],
        environment=[1.0, 1.0, 1.0],
    )
    ours = clrender_path_renders(scene, device)
    theirs = mitsuba_renders(scene, seeds=range(100, 100 + K))
    result = two_sample_z(ours, theirs)
    assert result.passed, f"clrender (a) vs Mitsuba (b)\n{result.report()}"
