"""Shadow shafts (kernels/shaft.h) against the per-ray shadow traversal they replace.

With -DSHADOW_SHAFTS=1 one traversal per shading point and area light collects what the light's
rays may cross and each ray is tested against that list only; with 0 every ray traverses the tree.
Both must see the same crossings: the same path ids, the same light visibility and the same image
(up to the order in which transmittances are multiplied).  The scenes are built to stress the
shaft's conservative tests: glass spheres overlapping meshes (shading points inside and on
spheres), lights close to and grazing the lit surfaces (shafts that straddle the tangent plane or
are nearly flat), occluders much smaller and much larger than the scene, whole scenes scaled far
from 1, and clouds of triangles that overflow the candidate list (the per-ray fallback).
"""

import numpy as np
import pytest

from clrender.scene.scene import Mesh, Scene
from clrender.trace.knobs import DEFAULT_KNOBS, TraceKnobs
from clrender.trace.renderer import Renderer
from clrender.trace.tracer import Tracer

W, H = 40, 30


def render_both(scene, knobs=DEFAULT_KNOBS, **settings):
    """The same render with shafts off (per-ray traversal) and on."""
    settings = {"width": W, "height": H, "aa": "full", "samples": 2, "seed": 3, **settings}
    off = Renderer(scene, tracer=Tracer(scene, shadow_shafts=False, knobs=knobs), **settings).run()
    on = Renderer(scene, tracer=Tracer(scene, shadow_shafts=True, knobs=knobs), **settings).run()
    return off, on


def assert_same_render(off, on):
    np.testing.assert_array_equal(on.path_ids, off.path_ids)
    np.testing.assert_allclose(on.shadow, off.shadow, rtol=0, atol=1e-6)
    np.testing.assert_allclose(on.image, off.image, rtol=0, atol=1e-6)


def soup(rng, n, centre, spread, size):
    """n random triangles of about `size` around `centre`."""
    tris = centre + rng.uniform(-spread, spread, (n, 1, 3)) + rng.normal(scale=size, size=(n, 3, 3))
    return Mesh(tris.reshape(-1, 3), np.arange(3 * n).reshape(-1, 3))


def stress_scene(scale=1.0, offset=(0.0, 0.0, 0.0), light_height=3.0, seed=5):
    """Glass spheres overlapping a triangle soup over a floor, a smooth-shaded hat, a tiny and a huge
    occluder, a square area light, all scaled by `scale` about the origin and then moved by `offset`."""
    rng = np.random.default_rng(seed)
    s, o = scale, np.asarray(offset)
    scene = Scene.from_dict(
        {
            "width": W,
            "height": H,
            "ambient": [0.05, 0.05, 0.05],
            "cameras": [{"position": list(o + s * np.array([0.2, 1.3, 2.6])), "look_at": list(o + s * np.array([0, 0.2, 0]))}],
            "materials": {
                "glass": {"transparency": 0.7, "ior": 1.5, "specular": [1, 1, 1], "shininess": 60},
                "clear": {"transparency": 0.5, "ior": 1.2},
                "matte": {"diffuse": [0.7, 0.6, 0.5], "specular": [0.2, 0.2, 0.2], "shininess": 10},
            },
            "lights": [
                {
                    "type": "area",
                    "corner": list(o + s * np.array([-0.8, light_height, -0.6])),
                    "edge_a": [s * 1.4, 0, 0],
                    "edge_b": [0, 0, s * 1.2],
                    "samples": 3,
                },
                {"type": "directional", "direction": [0.3, -1, -0.2], "intensity": 0.4},
            ],
            "objects": [
                {"type": "plane", "point": list(o + s * np.array([0, -0.5, 0])), "normal": [0, 1, 0], "size": 40 * s, "material": "matte"},
                # smooth shading: rays where the shading and the geometric normal disagree leave from the back
                {
                    "type": "mesh",
                    "generator": "wizard_hat",
                    "params": {"segments": 7},
                    "smooth": True,
                    "material": "matte",
                    "scale": s * 0.8,
                    "translate": list(o + s * np.array([0.9, -0.5, 0.6])),
                },
                {"type": "sphere", "center": list(o + s * np.array([-0.5, 0.1, 0.2])), "radius": 0.55 * s, "material": "glass"},
                {"type": "sphere", "center": list(o + s * np.array([0.7, 0.0, -0.3])), "radius": 0.4 * s, "material": "clear"},
                # a huge tilted occluder, far larger than the rest, cutting off part of the light
                {
                    "type": "triangle",
                    "material": "matte",
                    "vertices": [list(o + s * np.array(v)) for v in ([1.0, 2.0, -500.0], [1.0, 2.0, 500.0], [600.0, 2.6, 0.0])],
                },
            ],
        }
    )
    # a triangle soup through the glass sphere and beside it
    mesh = soup(rng, 60, np.array([-0.2, 0.3, 0.0]), 0.8, 0.15)
    scene.objects.append(Mesh(o + s * mesh.vertices, mesh.faces, material="matte"))
    # tiny occluders (1e-3 of the scene) hovering just above the floor and a sphere
    tiny = soup(rng, 40, np.array([0.2, -0.45, 0.3]), 0.6, 1e-3)
    scene.objects.append(Mesh(o + s * tiny.vertices, tiny.faces, material="matte"))
    return scene


def test_wizard_cat_renders_the_same_with_and_without_shafts(device):
    scene = Scene.load("wizard_cat")
    off, on = render_both(scene, camera=3, width=36, height=36)
    assert len(np.unique(off.ids)) >= 4  # cat, hat, sphere, floor in view
    assert 0.02 < (off.shadow[..., 0] < 1).mean() < 0.9  # some shadow from the area light
    assert_same_render(off, on)
    assert on.node_visits < off.node_visits / 2  # the shafts are in use: far fewer nodes visited


@pytest.mark.parametrize("scale, offset", [(1.0, (0, 0, 0)), (1e-3, (0, 0, 0)), (1e3, (0, 0, 0)), (1.0, (300, -50, 120))])
def test_spheres_meshes_and_occluders_of_every_size(device, scale, offset):
    off, on = render_both(stress_scene(scale, offset))
    assert {1, 2, 3, 5} <= set(np.unique(off.ids).tolist())  # the hat, both spheres and the soup are in view
    assert (off.shadow[..., 0] < 1).any() and (off.shadow[..., 0] > 0).any()
    assert_same_render(off, on)


@pytest.mark.parametrize("light_height", [-0.499, -0.49, -0.3])
def test_lights_close_to_and_grazing_the_floor(device, light_height):
    """The light just above the floor (1e-3 and 1e-2) and among the objects: shading points whose
    tangent plane cuts the light, shafts nearly flat, rays leaving from both sides."""
    off, on = render_both(stress_scene(light_height=light_height))
    assert_same_render(off, on)


def test_a_dense_cloud_overflows_the_candidates_and_falls_back(device):
    """Hundreds of small triangles between the floor and the light: more candidate blocks than
    TraceKnobs.shaft_candidates, so most shading points trace each ray through the tree."""
    rng = np.random.default_rng(11)
    scene = stress_scene()
    scene.objects.append(soup(rng, 800, np.array([0.0, 1.6, 0.0]), 1.0, 0.03))
    off, on = render_both(scene)
    assert 0 < off.shadow[..., 0].mean() < 1
    assert_same_render(off, on)


def test_a_one_block_candidate_list_still_gives_the_same_render(device):
    """One candidate block: almost every shaft overflows (fallback), the rest use one block."""
    off, on = render_both(stress_scene(), knobs=TraceKnobs(shaft_candidates=1))
    assert_same_render(off, on)


def test_shafts_are_deterministic(device):
    scene = stress_scene()
    a = Renderer(scene, width=W, height=H, aa="full", samples=2, seed=9).run()
    b = Renderer(scene, width=W, height=H, aa="full", samples=2, seed=9).run()
    np.testing.assert_array_equal(a.image, b.image)
