"""How a glass surface splits light between reflection and refraction, with what each path sees
coloured differently: total internal reflection sends all of it back, Schlick's F goes to the
reflection and 1 - F to the refraction, leaving glass F takes the angle on the air side.

A clear sheet (transparency 1, IOR 1.5) stands tilted in front of a red wall lit only by
ambient light, under a blue sky: a reflected or refracted ray sees red if it heads for the
wall and blue otherwise, so each pixel is F * (what the reflection sees) + (1 - F) * (what the
refraction sees), worked out here in float64.  A ray that meets the sheet from behind (its
normal pointing away) is leaving glass, as the medium rule of docs/shading.md says.
"""

import numpy as np
import pytest

from clrender.scene.scene import Scene
from clrender.trace.renderer import render

W, H = 40, 30
EYE = np.array([0.0, 0.0, 4.0])
FOV = 40.0
IOR = 1.5
SKY = np.array([0.2, 0.3, 0.5])
WALL = np.array([0.9, 0.1, 0.1])
WALL_Z = -6.0
HALF = 4.0  # the sheet is 8 x 8, centred on the origin


def sheet_scene(tilt_degrees, facing_camera):
    t = np.radians(tilt_degrees)
    u = np.array([np.cos(t), 0, -np.sin(t)])  # along the sheet, in the xz plane
    v = np.array([0.0, 1, 0])
    a, b = (2 * HALF * u, 2 * HALF * v) if facing_camera else (2 * HALF * v, 2 * HALF * u)  # normal a x b
    corner = -HALF * (u + v)
    normal = np.cross(a, b) / np.linalg.norm(np.cross(a, b))
    scene = Scene.from_dict(
        {
            "width": W,
            "height": H,
            "background": SKY.tolist(),
            "ambient": [1, 1, 1],
            "cameras": [{"position": EYE.tolist(), "look_at": [0, 0, 0], "fov": FOV}],
            "materials": {"glass": {"transparency": 1.0, "ior": IOR}, "wall": {"diffuse": WALL.tolist()}},
            "objects": [
                {"type": "quad", "corner": corner.tolist(), "edge_a": a.tolist(), "edge_b": b.tolist(), "material": "glass"},
                {"type": "quad", "corner": [-200, -200, WALL_Z], "edge_a": [400, 0, 0], "edge_b": [0, 400, 0], "material": "wall"},
            ],
        }
    )
    return scene, normal, u, v


def camera_rays():
    """Pixel-centre rays of the look-at camera (EYE towards the origin, up +y), row 0 at the top."""
    tan_half = np.tan(np.radians(FOV) / 2)
    ys, xs = np.mgrid[0:H, 0:W] + 0.5
    d = np.stack([(2 * xs / W - 1) * tan_half * W / H, (1 - 2 * ys / H) * tan_half, -np.ones_like(xs)], -1)
    return d / np.linalg.norm(d, axis=-1, keepdims=True)


def seen_along(direction):
    """What a ray from near the origin sees: the wall if it heads for it, else the sky."""
    return np.where((direction[..., 2] < 0)[..., None], WALL, SKY)


def expected_image(normal, u, v, fresnel):
    """(expected colours, usable-pixel mask, total-internal-reflection mask)."""
    d = camera_rays()
    t = -(EYE @ normal) / (d @ normal)  # the sheet's plane passes through the origin
    p = EYE + t[..., None] * d
    on_sheet = (np.abs(p @ u) < HALF - 0.3) & (np.abs(p @ v) < HALF - 0.3)
    entering = normal @ (-d[0, 0]) > 0  # the sheet faces the camera
    n1, n2 = (1.0, IOR) if entering else (IOR, 1.0)
    n = np.where(((d @ normal) < 0)[..., None], normal, -normal)  # facing the incoming ray
    cos_i = -(d * n).sum(-1)
    eta = n1 / n2
    sin2_t = eta**2 * (1 - cos_i**2)
    tir = sin2_t > 1
    cos_t = np.sqrt(np.clip(1 - sin2_t, 0, None))
    reflected = d + 2 * cos_i[..., None] * n
    refracted = eta * d + (eta * cos_i - cos_t)[..., None] * n
    if fresnel:
        r0 = ((n1 - n2) / (n1 + n2)) ** 2
        c = cos_i if n1 <= n2 else cos_t  # Schlick: the angle on the air side
        F = r0 + (1 - r0) * (1 - c) ** 5
    else:
        F = np.zeros_like(cos_i)
    F = np.where(tir, 1.0, F)
    colour = F[..., None] * seen_along(reflected) + (1 - F)[..., None] * seen_along(refracted)
    # away from the critical angle and from rays that skim the wall's plane
    usable = on_sheet & (np.abs(sin2_t - 1) > 0.03) & (np.abs(reflected[..., 2]) > 0.05) & (tir | (np.abs(refracted[..., 2]) > 0.05))
    return colour, usable, tir


def test_past_the_critical_angle_leaving_glass_all_the_light_is_reflected(device):
    scene, normal, u, v = sheet_scene(40, facing_camera=False)
    image = render(scene)
    expected, usable, tir = expected_image(normal, u, v, fresnel=False)
    assert (usable & tir).sum() > 100 and (usable & ~tir).sum() > 100  # both sides of the critical angle
    np.testing.assert_allclose(image[usable], expected[usable], atol=1e-5)


@pytest.mark.parametrize("facing_camera", [True, False], ids=["entering", "leaving"])
def test_schlick_sends_F_to_the_reflection_and_1_minus_F_to_the_refraction(device, facing_camera):
    scene, normal, u, v = sheet_scene(40, facing_camera)
    image = render(scene, fresnel=True)
    expected, usable, tir = expected_image(normal, u, v, fresnel=True)
    assert (usable & ~tir).sum() > 100
    # the split matters here: the two paths see different colours on many pixels
    plain, _, _ = expected_image(normal, u, v, fresnel=False)
    assert (np.abs(plain - expected).max(-1)[usable] > 5e-3).mean() > 0.5
    np.testing.assert_allclose(image[usable], expected[usable], atol=1e-5)
