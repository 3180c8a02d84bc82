"""The spot light (kernels/spot.h, scene/lights.py): the radiance a white Lambert plane under it shows, with the path
tracer's direct lighting, against the analytic profile (Mitsuba 3's and pbrt-v4's falloffs, tests/reference/bsdf64.py's
spot_profile) and the inverse-square law; the Whitted integrator draws it as a point light times the same profile.

The plane y = 0 seen straight down by an orthographic camera 4 units across: each pixel's value is the mean over
`spp` random points of the pixel of L(x) = (1 / pi) I profile(theta) cos(theta_s) / r^2, so the reference is the
pixel-area mean of L (a 16 x 16 midpoint rule) and each pixel is z-tested against the spread of L over the pixel
/ sqrt(spp), at 4.5 sigma per pixel (Sidak over 1024 pixels: about 0.7 % for the whole image, for Gaussian errors)."""

import math

import numpy as np
import pytest

import clrender
from clrender.errors import UsageError
from clrender.scene.scene import Scene

from tests.reference import bsdf64 as ref

SIZE, HALF, SPP = 32, 2.0, 256
LIGHT_AT, INTENSITY = np.array([0.3, 1.0, -0.2]), 5.0


def spot_scene(axis, cutoff, beam, profile, falloff=None) -> dict:
    light = {"type": "spot", "position": LIGHT_AT.tolist(), "direction": list(axis), "cutoff_angle": cutoff, "beam_width": beam, "profile": profile}
    light.update(intensity=INTENSITY, color=[1.0, 0.5, 0.25])
    if falloff:
        light["falloff"] = falloff
    view = {"position": [0, 5, 0], "look_at": [0, 0, 0], "up": [0, 0, -1], "projection": "orthographic", "ortho_height": 2 * HALF}
    return {
        "width": SIZE,
        "height": SIZE,
        "cameras": [view],
        "materials": {"white": {"diffuse": [1, 1, 1]}},
        "objects": [{"type": "plane", "point": [0, 0, 0], "normal": [0, 1, 0], "size": 10, "material": "white"}],
        "lights": [light],
    }


def analytic(axis, cutoff, beam, profile, sub=16):
    """Per pixel: the mean and standard deviation of L over its area (x = +right, z = -up: the camera's frame)."""
    axis = np.asarray(axis, np.float64) / np.linalg.norm(axis)
    f = (np.arange(SIZE * sub) + 0.5) / (SIZE * sub)
    x = (2 * f - 1) * HALF
    z = (2 * f - 1) * HALF  # sy = 1 - 2 v: z = -sy HALF
    X, Z = np.meshgrid(x, z)
    d = np.stack([X - LIGHT_AT[0], -LIGHT_AT[1] + 0 * X, Z - LIGHT_AT[2]], axis=-1)
    r2 = np.sum(d * d, axis=-1)
    d = d / np.sqrt(r2)[..., None]
    value = ref.spot_profile(d @ axis, cutoff, beam, profile) * (-d[..., 1]) / r2 * INTENSITY / math.pi
    blocks = value.reshape(SIZE, sub, SIZE, sub)
    return blocks.mean(axis=(1, 3)), blocks.std(axis=(1, 3))


CASES = [
    ((0, -1, 0), 40.0, 20.0, "mitsuba"),
    ((0.4, -1, 0.2), 35.0, 30.0, "pbrt"),
    pytest.param((-0.3, -1, 0.5), 50.0, 10.0, "mitsuba", marks=pytest.mark.slow),
    pytest.param((0, -1, 0), 45.0, 0.0, "pbrt", marks=pytest.mark.slow),
]


@pytest.mark.parametrize("axis, cutoff, beam, profile", CASES)
def test_irradiance_on_a_plane_follows_the_profile_and_the_inverse_square_law(axis, cutoff, beam, profile):
    image = clrender.render(spot_scene(axis, cutoff, beam, profile), integrator="path", spp=SPP, seed=5, max_depth=0)
    mean, std = analytic(axis, cutoff, beam, profile)
    colour = np.array([1.0, 0.5, 0.25])
    got = image[..., :3] / colour
    z = np.abs(got - mean[..., None]) / (std[..., None] / math.sqrt(SPP) + 1e-6 * mean.max())
    assert (mean > 0).mean() > 0.1 and (mean == 0).mean() > 0.1  # the cone's edge lies inside the image
    assert z.max() < 4.5, f"worst pixel {np.unravel_index(z.argmax(), z.shape)}: got {got.reshape(-1)[z.argmax()]}"


def test_the_two_profiles_differ_where_they_should():
    """Mitsuba's falloff is linear in the angle, pbrt's a smoothstep in the cosine: the same cone, different images."""
    a, _ = analytic((0, -1, 0), 40.0, 20.0, "mitsuba")
    b, _ = analytic((0, -1, 0), 40.0, 20.0, "pbrt")
    assert np.abs(a - b).max() > 0.05 * a.max()
    assert ref.spot_profile(math.cos(math.radians(30.0)), 40.0, 20.0, "mitsuba") == pytest.approx(0.5)


def test_whitted_draws_the_spot_as_a_point_light_times_its_profile():
    """The Whitted tracer's physical point light: kd I c cos / r^2 (its energy-conserving BRDF kd / pi times pi E ... as
    scene/lights.py states), here with kd = 1, at each pixel centre, times the profile."""
    axis, cutoff, beam = (0.4, -1, 0.2), 35.0, 30.0
    scene = spot_scene(axis, cutoff, beam, "mitsuba")
    image = clrender.render(scene, integrator="whitted")[..., :3] / np.array([1.0, 0.5, 0.25])
    mean, _ = analytic(axis, cutoff, beam, "mitsuba", sub=1)  # the pixel centres
    lit = image.max(axis=-1) > 0
    assert lit.mean() > 0.1 and (~lit).mean() > 0.1
    ratio = image[..., 0][mean > 0.05 * mean.max()] / mean[mean > 0.05 * mean.max()]
    np.testing.assert_allclose(ratio, ratio.mean(), rtol=2e-3)  # the same shape: a constant factor (the BRDF's 1 / pi or 1)
    assert ratio.mean() == pytest.approx(1.0, rel=2e-3) or ratio.mean() == pytest.approx(math.pi, rel=2e-3)
    assert (image[..., 0][mean == 0] == 0).all()


@pytest.mark.parametrize(
    "change, message",
    [({"beam_width": 50.0}, "wider than cutoff_angle"), ({"falloff": "none"}, "spot light is physical"), ({"profile": "ies"}, "not one of")],
)
def test_bad_spot_settings_give_one_line(change, message):
    scene = spot_scene((0, -1, 0), 40.0, 20.0, "mitsuba")
    scene["lights"][0].update(change)
    with pytest.raises(UsageError, match=message):
        Scene.from_dict(scene)
