"""The lobes of kernels/bsdf_exchange.h inside the path tracer (kernels/path.cl): a sphere of each material under a
constant environment of radiance 0.5, seen head-on through a narrow camera (every pixel within 3 degrees of normal
incidence), so each pixel's expected value is 0.5 x the material's directional albedo at normal incidence, from the
float64 references (tests/reference/bsdf64.py).  That exercises the component choice, the delta flags, next-event
estimation of the environment and its MIS weights with each lobe: an error in any of them biases the mean.
Means over the 64 pixels are z-tested at 4.5 sigma (pixel-to-pixel spread / 8)."""

import math

import numpy as np
import pytest

import clrender

from tests.reference import bsdf64 as ref
from tests.reference.sphere_chi2 import cell_integrals

ENV = 0.5


def sphere_scene(material: dict) -> dict:
    view = {"position": [0, 0, 3], "look_at": [0, 0, 0], "up": [0, 1, 0], "fov": 2.0}
    return {
        "width": 8,
        "height": 8,
        "cameras": [view],
        "materials": {"m": material},
        "objects": [{"type": "sphere", "center": [0, 0, 0], "radius": 1, "material": "m"}],
        "environment": {"color": [ENV] * 3},
    }


def render_mean(material: dict, spp: int = 256, max_depth: int = 8):
    image = clrender.render(sphere_scene(material), integrator="path", spp=spp, seed=11, max_depth=max_depth)[..., :3]
    pixels = image.reshape(-1, 3).astype(np.float64)
    return pixels.mean(axis=0), pixels.std(axis=0) / math.sqrt(len(pixels)), pixels


def normal_albedo(f):
    """The integral over the sphere of f(wi) = eval(wo = +z, wi) per channel (adaptive Gauss-Legendre)."""
    return np.array([cell_integrals(lambda d, c=c: f(d)[:, c], 10**8).sum() for c in range(3)])


def test_an_opaque_smooth_conductor_reflects_the_environment_times_tint():
    tint = np.array([0.9, 0.6, 0.3])
    mean, _, pixels = render_mean({"type": "conductor", "eta": [1, 1, 1], "k": [1e3] * 3, "tint": tint.tolist()}, spp=4)
    np.testing.assert_allclose(pixels, np.tile(ENV * tint, (64, 1)), rtol=2e-5)  # F = 0.999996: a delta, no noise


@pytest.mark.parametrize("roughness", [0.4, 0.8])
def test_a_rough_conductor_keeps_what_single_scattering_keeps(roughness):
    tint = np.array([0.9, 0.6, 0.3])
    mean, se, _ = render_mean({"type": "conductor", "eta": [1, 1, 1], "k": [1e3] * 3, "tint": tint.tolist(), "roughness": roughness})
    want = ENV * tint * ref.conductor_albedo_f1(0.0, roughness**2) * 0.999996
    assert (np.abs(mean - want) < 4.5 * se + 1e-4).all(), (mean, want)


def test_a_lossless_thin_sheet_passes_the_environment_unchanged():
    mean, se, _ = render_mean({"type": "thin_dielectric", "ior": 1.5})
    assert (np.abs(mean - ENV) < 4.5 * se + 1e-5).all(), (mean, se)
    tinted, se, _ = render_mean({"type": "thin_dielectric", "ior": 1.5, "tint": [0, 0, 0], "transmittance": [0.5, 0.5, 0.5]})
    r = ref.thin_dielectric_reflectance(np.array([1.0]), 1.5)[0]  # through two faces of the sheet: (0.5 (1 - R'))^2
    assert (np.abs(tinted - ENV * (0.5 * (1 - r)) ** 2) < 4.5 * se + 1e-4).all(), (tinted, r)


@pytest.mark.parametrize("roughness, smith", [(0.0, "correlated"), (0.3, "correlated"), (0.6, "separable")])
def test_a_coated_diffuse_shows_its_albedo(roughness, smith):
    from clrender.scene.materials import Material

    diffuse, tint = (0.7, 0.35, 0.1), (1.0, 0.9, 0.8)
    material = {"type": "coated_diffuse", "diffuse": list(diffuse), "ior": 1.5, "roughness": roughness, "tint": list(tint), "smith": smith}
    mean, se, _ = render_mean(material)
    wo = lambda d: np.broadcast_to([0.0, 0.0, 1.0], d.shape)
    if roughness == 0:
        albedo = normal_albedo(lambda d: ref.coated_smooth_eval(wo(d), d, diffuse, 1.5))
        albedo += np.array(tint) * ref.fresnel_dielectric(np.array([1.0]), 1.0, 1.5)[0]
    else:
        m = Material(kind="coated_diffuse", diffuse=diffuse, lobe_ior=1.5, roughness=roughness, tint=tint, smith=smith)
        alpha = float(np.float32(roughness) ** 2)
        args = (diffuse, tint, 1.5, alpha, m.coat_transmittance, m.coat_internal, smith)
        albedo = normal_albedo(lambda d: ref.coated_rough_eval(wo(d), d, *args))
    assert (np.abs(mean - ENV * albedo) < 4.5 * se + 2e-4).all(), (mean, ENV * albedo, se)


@pytest.mark.parametrize(
    "material, stand_in",
    [
        ({"type": "conductor", "eta": [0.2, 0.9, 1.1], "k": [3.9, 2.5, 2.1], "roughness": 0.3}, None),
        ({"type": "coated_diffuse", "diffuse": [0.7, 0.35, 0.1], "roughness": 0.2}, {"diffuse": [0.7, 0.35, 0.1]}),
        ({"type": "thin_dielectric", "ior": 1.5}, {"diffuse": [0, 0, 0], "transparency": 1.0, "ior": 1.0}),
    ],
)
def test_whitted_draws_each_type_as_its_documented_stand_in(material, stand_in):
    """docs/materials.md: a conductor as Lambert of its normal reflectance, a coated diffuse as Lambert of its base, a
    thin sheet as clear glass of IOR 1; the same image (to float32 rounding of kd) as the stand-in as a seed material."""
    if stand_in is None:
        eta, k = np.array(material["eta"]), np.array(material["k"])
        stand_in = {"diffuse": (((eta - 1) ** 2 + k**2) / ((eta + 1) ** 2 + k**2)).tolist()}
    lit = lambda m: {**sphere_scene(m), "lights": [{"type": "point", "position": [2, 3, 4]}], "background": [0.2, 0.3, 0.4]}
    a = clrender.render(lit(material), integrator="whitted")
    b = clrender.render(lit(stand_in), integrator="whitted")
    assert np.abs(a - b).max() < 1e-6 and a.max() > 0
