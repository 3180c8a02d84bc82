"""Alpha-tested materials (kernels/alpha.h) in the Whitted integrator: a card whose alpha texture is a checker
(MASK) hangs between a point light and a floor; camera rays see the floor through its holes and shadow rays
reach the floor through them, exactly where the texel the shadow ray crosses has alpha < cutoff (projected
analytically here: no renderer code).  BLEND: a deterministic blend (alpha x the card + (1 - alpha) x the floor)
and a shadow transmittance 1 - alpha."""

import numpy as np
import pytest

import clrender

from tests.scenetools import CHECKER, write_checker

N = 48  # image side
VIEW = 3.0  # the orthographic camera sees x, y in [-1.5, 1.5]
CARD_Z, LIGHT = 1.0, np.array([0.3, 0.2, 2.0])  # the card at z = 1 over [-1, 1]^2; the floor at z = 0
MARGIN = 0.06  # texels: pixels whose camera or shadow ray passes this close to a texel edge are not compared


def scene(tmp_path, alpha: dict, texture=True):
    from clrender.scene.scene import Scene

    write_checker(tmp_path)
    card = {"diffuse": [1, 0, 0], "alpha": alpha, **({"diffuse_texture": "checker"} if texture else {})}
    return Scene.from_dict(
        {
            "width": N,
            "height": N,
            "cameras": [{"position": [0, 0, 10], "look_at": [0, 0, 0], "projection": "orthographic", "ortho_height": VIEW}],
            "textures": {"checker": {"file": "checker.png", "filter": "nearest", "wrap_s": "clamp_to_edge", "wrap_t": "clamp_to_edge"}},
            "materials": {"card": card, "floor": {"diffuse": [1, 1, 1]}},
            "lights": [{"type": "point", "position": LIGHT.tolist()}],
            "objects": [
                {"type": "quad", "corner": [-1, -1, CARD_Z], "edge_a": [2, 0, 0], "edge_b": [0, 2, 0], "material": "card"},
                {"type": "quad", "corner": [-4, -4, 0], "edge_a": [8, 0, 0], "edge_b": [0, 8, 0], "material": "floor"},
            ],
        },
        base_dir=tmp_path,
    )


def card_texel(x, y):
    """(on the card, texel alpha is 1, distance to the nearest texel edge in texels) of card points (x, y); UV (0, 0)
    is the card's corner (-1, 1) (textured quads map u along edge_a, v down edge_b's reverse)."""
    u, v = (x + 1) / 2 * CHECKER, (1 - y) / 2 * CHECKER
    on = (u > 0) & (u < CHECKER) & (v > 0) & (v < CHECKER)
    i, j = np.floor(u).astype(int), np.floor(v).astype(int)
    edge = np.minimum(np.abs(u - np.round(u)), np.abs(v - np.round(v)))
    return on, (i + j) % 2 == 0, edge


def expected(blend=None, shift=(0.0, 0.0)):
    """Each pixel's colour and a mask of the pixels far from texel edges.  The point light (falloff none) gives
    kd cos(theta); blend: None for MASK (cutoff 0.5), else the card's alpha where the checker is opaque."""
    c = ((np.arange(N) + 0.5) / N * 2 - 1) * VIEW / 2
    x, y = np.meshgrid(c + shift[0], -c + shift[1])  # row 0 is the image's top; shift: a point off the pixel centres
    on_card, solid, edge_cam = card_texel(x, y)
    floor = np.stack([x, y, np.zeros_like(x)], -1)
    to_light = LIGHT - floor
    s = CARD_Z / to_light[..., 2]  # the shadow ray meets the card's plane at floor + s to_light
    sx, sy = x + s * to_light[..., 0], y + s * to_light[..., 1]
    shadow_on, shadow_solid, edge_shadow = card_texel(sx, sy)
    cos_floor = to_light[..., 2] / np.linalg.norm(to_light, axis=-1)
    a = 1.0 if blend is None else blend
    floor_T = np.where(shadow_on & shadow_solid, 1 - a, 1.0)
    floor_colour = (floor_T * cos_floor)[..., None] * [1, 1, 1]
    card_p = np.stack([x, y, np.full_like(x, CARD_Z)], -1)
    to_light_card = LIGHT - card_p
    cos_card = to_light_card[..., 2] / np.linalg.norm(to_light_card, axis=-1)
    card_colour = cos_card[..., None] * [1, 0, 0]
    seen = on_card & solid
    image = np.where(seen[..., None], a * card_colour + (1 - a) * floor_colour, floor_colour)
    far = ~(on_card & (edge_cam < MARGIN)) & ~(shadow_on & (edge_shadow < MARGIN))
    far &= (np.abs(np.abs(x) - 1) > 0.05) & (np.abs(np.abs(y) - 1) > 0.05) & (np.abs(np.abs(sx) - 1) > 0.05) & (np.abs(np.abs(sy) - 1) > 0.05)
    return image, far, seen, shadow_on & shadow_solid


def test_mask_card_lets_camera_and_shadow_rays_through_its_holes(tmp_path):
    image = clrender.Renderer(scene(tmp_path, {"mode": "mask", "cutoff": 0.5}), aa="none").run().image.astype(np.float64)
    want, far, seen, shadowed = expected()
    assert far.mean() > 0.5
    # every kind of pixel is there: card, floor through a hole lit, floor through a hole in shadow, floor past the card
    assert (far & seen).any() and (far & ~seen & shadowed).any() and (far & ~seen & ~shadowed).any()
    np.testing.assert_allclose(image[far], want[far], atol=2e-5)


def test_mask_without_the_texture_is_the_factor_against_the_cutoff(tmp_path):
    """factor 0.4 < cutoff 0.5 everywhere: the card is not there at all, the floor fully lit."""
    image = clrender.Renderer(scene(tmp_path, {"mode": "mask", "cutoff": 0.5, "factor": 0.4}, texture=False), aa="none").run().image
    want, far, _, _ = expected(blend=0.0)
    np.testing.assert_allclose(image[far], want[far], atol=2e-5)


@pytest.mark.parametrize("a", [0.25, 0.7])
def test_blend_is_a_blend_and_a_shadow_transmittance(tmp_path, a):
    image = clrender.Renderer(scene(tmp_path, {"mode": "blend", "factor": a}), aa="none").run().image.astype(np.float64)
    want, far, seen, _ = expected(blend=a)
    assert (far & seen).any()
    np.testing.assert_allclose(image[far], want[far], atol=3e-5)


def test_path_tracer_agrees_on_the_mask(tmp_path):
    """The path tracer's MASK (shared alpha test, kernels/alpha.h) against the same projection: one jittered ray a
    pixel: the pixels whose corners all show the same (card or floor, lit or not) are compared, the tolerance covers
    the cosine's change over a pixel."""
    image = clrender.Renderer(scene(tmp_path, {"mode": "mask", "cutoff": 0.5}), integrator="path", spp=1, max_depth=0).run().image
    want, far, seen, shadowed = expected()
    half = VIEW / N / 2  # a pixel's half width in world units: the pixels whose whole area shows one kind are kept
    keep = far.copy()
    for shift in ((-half, -half), (-half, half), (half, -half), (half, half)):
        _, _, seen_there, shadowed_there = expected(shift=shift)
        keep &= (seen_there == seen) & (shadowed_there == shadowed)
    assert keep.mean() > 0.3
    np.testing.assert_allclose(image[keep], want[keep], atol=0.02)


def geometry_card_scene(tmp_path, alpha_card: bool, lights, floor_mirror=0.0):
    """The checker card as alpha (MASK) or as its opaque texels modelled as eight small quads (no alpha: the
    renderer's ordinary kernels, shadow shafts included), over a floor with some mirror reflection."""
    from clrender.scene.scene import Scene

    write_checker(tmp_path)

    data = {
        "width": N,
        "height": N,
        "background": [0.3, 0.5, 0.7],
        "cameras": [{"position": [0, 0, 10], "look_at": [0, 0, 0], "projection": "orthographic", "ortho_height": VIEW}],
        "textures": {"checker": {"file": "checker.png", "filter": "nearest", "wrap_s": "clamp_to_edge", "wrap_t": "clamp_to_edge"}},
        "materials": {
            "card": {"diffuse": [1, 0, 0], **({"diffuse_texture": "checker", "alpha": {"mode": "mask"}} if alpha_card else {})},
            "floor": {"diffuse": [1, 1, 1], "mirror": floor_mirror},
        },
        "lights": lights,
        "objects": [{"type": "quad", "corner": [-4, -4, 0], "edge_a": [8, 0, 0], "edge_b": [0, 8, 0], "material": "floor"}],
    }
    side = 2 / CHECKER
    if alpha_card:
        data["objects"].append({"type": "quad", "corner": [-1, -1, CARD_Z], "edge_a": [2, 0, 0], "edge_b": [0, 2, 0], "material": "card"})
    else:  # texel (i, j): x from -1 + i side, y from 1 - (j + 1) side
        for j in range(CHECKER):
            for i in range(CHECKER):
                if (i + j) % 2 == 0:
                    corner = [-1 + i * side, 1 - (j + 1) * side, CARD_Z]
                    data["objects"].append({"type": "quad", "corner": corner, "edge_a": [side, 0, 0], "edge_b": [0, side, 0], "material": "card"})
    return Scene.from_dict(data, base_dir=tmp_path)


@pytest.mark.parametrize(
    "lights, floor_mirror",
    [
        ([{"type": "area", "corner": [-0.5, -0.3, 2.0], "edge_a": [1.0, 0, 0], "edge_b": [0, 0.8, 0], "samples": 4}], 0.0),
        ([{"type": "point", "position": LIGHT.tolist()}], 0.5),
    ],
    ids=["area-light", "mirror-floor"],
)
def test_mask_card_renders_as_its_opaque_texels_modelled_as_geometry(tmp_path, lights, floor_mirror):
    """Two independent ways to the same picture: the alpha-tested card (ALPHA_TEST variant: shadow rays walk hit by
    hit, no shafts) and its opaque texels as quads (the ordinary kernels, shafts on).  Area-light shadow rays and
    mirror rays from the floor (which see the background through the holes and the card's unlit back elsewhere)
    must pass the holes exactly where the geometry has none."""
    alpha = clrender.Renderer(geometry_card_scene(tmp_path, True, lights, floor_mirror), aa="none").run().image.astype(np.float64)
    geometry = clrender.Renderer(geometry_card_scene(tmp_path, False, lights, floor_mirror), aa="none").run().image.astype(np.float64)
    _, far, seen, _ = expected()
    assert (far & seen).any() and (far & ~seen).any()
    np.testing.assert_allclose(alpha[far], geometry[far], atol=2e-5)
