"""Single-sided materials (glTF doubleSided false, kernels/alpha.h): camera rays look past their back faces, every
other ray (shadow, bounce) still meets them.  A card at z = 1 and a ceiling at z = 2, both facing -z; a light below
shines up at an angle (along +y), so the card shadows a strip of the ceiling that a camera below sees beside it."""

import math

import numpy as np
import pytest

import clrender

N = 30
VIEW = 3.0  # the orthographic cameras see x, y in [-1.5, 1.5]
BACKGROUND = (0.2, 0.4, 0.6)
LIGHT = np.array([0.0, 0.5, 1.0])  # the direction light travels: up and towards +y
COS = 1 / math.sqrt(1.25)  # n . l for surfaces facing -z


def scene(camera_z, card_double_sided, ceiling_double_sided=True, **extra):
    from clrender.scene.scene import Scene

    return Scene.from_dict(
        {
            **extra,
            "width": N,
            "height": N,
            "background": list(BACKGROUND),
            "cameras": [{"position": [0, 0, camera_z], "look_at": [0, 0, 1], "up": [0, 1, 0], "projection": "orthographic", "ortho_height": VIEW}],
            "materials": {
                "card": {"diffuse": [1, 0, 0], "double_sided": card_double_sided},
                "ceiling": {"diffuse": [1, 1, 1], "double_sided": ceiling_double_sided},
            },
            "lights": [{"type": "directional", "direction": LIGHT.tolist()}],
            "objects": [  # both face -z: edge_a x edge_b = y x x
                {"type": "quad", "corner": [-1, -1, 1], "edge_a": [0, 2, 0], "edge_b": [2, 0, 0], "material": "card"},
                {"type": "quad", "corner": [-4, -4, 2], "edge_a": [0, 8, 0], "edge_b": [8, 0, 0], "material": "ceiling"},
            ],
        }
    )


def grid():
    c = ((np.arange(N) + 0.5) / N * 2 - 1) * VIEW / 2
    return np.meshgrid(c, -c)  # row 0 is the image's top (+y); columns symmetric in x


@pytest.mark.parametrize("integrator", ["whitted", "path"])
def test_camera_rays_do_not_see_back_faces(integrator):
    """From above, both single-sided quads show their backs: the camera sees the background through them."""
    kw = {"integrator": "path", "spp": 1, "max_depth": 0} if integrator == "path" else {}
    extra = {"environment": {"color": list(BACKGROUND)}} if integrator == "path" else {}  # what the path tracer's misses see
    image = clrender.Renderer(scene(10, False, False, **extra), aa="none", **kw).run().image
    np.testing.assert_allclose(image, np.broadcast_to(BACKGROUND, image.shape), atol=1e-6)


def test_double_sided_back_faces_are_drawn():
    """The card double-sided (and the ceiling single-sided): from above, its back (shaded with the normal turned to
    the camera, so facing away from the light below: black) hides the background."""
    image = clrender.Renderer(scene(10, True, False), aa="none").run().image
    x, y = grid()
    card = (np.abs(x) < 0.95) & (np.abs(y) < 0.95)
    away = (np.abs(x) > 1.05) | (np.abs(y) > 1.05)
    np.testing.assert_allclose(image[card], 0.0, atol=1e-6)
    np.testing.assert_allclose(image[away], np.broadcast_to(BACKGROUND, image[away].shape), atol=1e-6)


def test_shadow_rays_meet_single_sided_back_faces():
    """From below, the camera sees the card's front (lit: red cos) and the ceiling beside it; the ceiling's shadow
    rays go down towards the light and meet the card's back face: the strip y in (1, 1.5)
    over |x| < 1 is in shadow, the rest of the ceiling lit (cos)."""
    image = clrender.Renderer(scene(-10, False), aa="none").run().image
    x, y = grid()
    # seen from below with up +y the rows still run from +y down; the columns are mirrored, which |x| ignores
    card = (np.abs(x) < 0.95) & (np.abs(y) < 0.95)
    shadow = (np.abs(x) < 0.95) & (y > 1.05) & (y < 1.45)
    lit = (np.abs(x) > 1.05) | (y < -1.05)
    assert shadow.any() and lit.any()
    np.testing.assert_allclose(image[card], np.broadcast_to([COS, 0, 0], image[card].shape), rtol=1e-5)
    np.testing.assert_allclose(image[shadow], 0.0, atol=1e-6)
    np.testing.assert_allclose(image[lit], np.broadcast_to([COS] * 3, image[lit].shape), rtol=1e-5)
