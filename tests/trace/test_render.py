"""Whole renders: shading against analytic values, BVH on/off agreement, determinism, the edge-AA identities."""

import numpy as np
import pytest

from clrender.scene.scene import Mesh, Scene
from clrender.trace.renderer import Renderer, render
from clrender.trace.tracer import Tracer

W, H = 48, 36


def lit_floor_scene(**light):
    return Scene.from_dict(
        {
            "width": W,
            "height": H,
            "ambient": [0.1, 0.1, 0.1],
            "cameras": [{"position": [0, 4, 4], "look_at": [0, 0, 0]}],
            "materials": {"floor": {"diffuse": [0.5, 0.6, 0.7], "specular": [0, 0, 0]}},
            "lights": [{"type": "point", "position": [1, 5, 1], "intensity": 0.8, **light}],
            "objects": [
                {"type": "plane", "point": [0, 0, 0], "normal": [0, 1, 0], "size": 40, "material": "floor"},
                {"type": "sphere", "center": [0.5, 2.5, 0.5], "radius": 0.5},
            ],
        }
    )


def pinhole_rays(position, look_at, up=(0, 1, 0), fov=60.0, width=W, height=H):
    """Pixel-centre rays of a look-at pinhole camera, written out here rather than taken from
    clrender.Camera (whose frame the kernel also uses), so the camera geometry is checked too:
    row 0 at the top, vertical field of view `fov`, square pixels."""
    eye = np.asarray(position, float)
    forward = np.asarray(look_at, float) - eye
    forward /= np.linalg.norm(forward)
    right = np.cross(forward, up)
    right /= np.linalg.norm(right)
    true_up = np.cross(right, forward)
    tan_half = np.tan(np.radians(fov) / 2)
    ys, xs = np.mgrid[0:height, 0:width] + 0.5
    u = (2 * xs / width - 1) * tan_half * width / height
    v = (1 - 2 * ys / height) * tan_half
    d = forward + u[..., None] * right + v[..., None] * true_up
    return np.broadcast_to(eye, d.shape), d / np.linalg.norm(d, axis=-1, keepdims=True)


def floor_hits(scene):
    o, d = pinhole_rays([0, 4, 4], [0, 0, 0])  # lit_floor_scene's camera
    t = -o[..., 1] / d[..., 1]
    return o + t[..., None] * d


def test_lambert_shading_and_hard_shadow_match_the_analytic_values(device):
    scene = lit_floor_scene()
    result = Renderer(scene, bvh=False).run()
    kd = np.array([0.5, 0.6, 0.7])
    p = floor_hits(scene)
    light = np.array([1.0, 5, 1])
    to_light = light - p
    cos = to_light[..., 1] / np.linalg.norm(to_light, axis=-1)
    # the sphere blocks the light where the segment p -> light passes within its radius
    centre = np.array([0.5, 2.5, 0.5])
    dist = to_light / np.linalg.norm(to_light, axis=-1, keepdims=True)
    along = ((centre - p) * dist).sum(-1)
    miss = np.linalg.norm(p + along[..., None] * dist - centre, axis=-1)
    shadowed = miss < 0.5
    expected = 0.1 * kd + (~shadowed)[..., None] * 0.8 * cos[..., None] * kd
    floor = (result.ids == 0) & (np.abs(miss - 0.5) > 0.02)  # away from the shadow's edge
    assert shadowed[floor].sum() > 10 and (~shadowed[floor]).sum() > 100
    np.testing.assert_allclose(result.image[floor], expected[floor], rtol=2e-4, atol=2e-5)
    assert ((result.shadow[..., 0] == 0) == shadowed)[floor].all()


def test_inverse_square_point_light(device):
    scene = lit_floor_scene(falloff="inverse_square")
    image = render(scene, bvh=False)
    p = floor_hits(scene)
    to_light = np.array([1.0, 5, 1]) - p
    r2 = (to_light**2).sum(-1)
    cos = to_light[..., 1] / np.sqrt(r2)
    expected = 0.1 * 0.5 + 0.8 * cos / r2 * 0.5 / np.pi  # ambient kd + I cos / r^2 * kd / pi (the physical model)
    y, x = 30, 5  # a floor pixel far from the sphere's shadow
    assert image[y, x, 0] == pytest.approx(expected[y, x], rel=1e-4)


def mixed_scene():
    """Spheres, a mirror, glass and a triangle soup: every kind of ray."""
    rng = np.random.default_rng(8)
    scene = Scene.from_dict(
        {
            "width": W,
            "height": H,
            "ambient": [0.05, 0.05, 0.05],
            "background": [0.2, 0.3, 0.5],
            "cameras": [{"position": [0, 1, 6], "look_at": [0, 0, 0]}],
            "materials": {
                "mirror": {"mirror": 0.8, "diffuse": [0.2, 0.2, 0.2]},
                "glass": {"transparency": 0.9, "ior": 1.5, "specular": [0.5, 0.5, 0.5], "shininess": 80},
                "red": {"diffuse": [0.9, 0.1, 0.1], "specular": [0.3, 0.3, 0.3], "shininess": 20},
            },
            "lights": [
                {"type": "point", "position": [3, 5, 4]},
                {"type": "area", "corner": [-2, 4, -1], "edge_a": [1, 0, 0], "edge_b": [0, 0, 1], "samples": 3},
            ],
            "objects": [
                {"type": "sphere", "center": [-1.2, 0, 0], "radius": 0.8, "material": "glass"},
                {"type": "sphere", "center": [1.2, 0, -0.5], "radius": 0.8, "material": "mirror"},
                {"type": "sphere", "center": [0, 0.3, -2.5], "radius": 0.7, "material": "red"},
                {"type": "plane", "point": [0, -0.8, 0], "normal": [0, 1, 0], "size": 30},
            ],
        }
    )
    tris = rng.uniform(-2.5, 2.5, (150, 1, 3)) * [1, 0.4, 1] + [0, 0.8, -3] + rng.normal(scale=0.3, size=(150, 3, 3))
    scene.objects.append(Mesh(tris.reshape(-1, 3), np.arange(450).reshape(-1, 3), material="red"))
    return scene


def test_bvh_on_off_and_both_builders_render_the_same_image(device):
    scene = mixed_scene()
    results = [Renderer(scene, bvh=b, bvh_builder=k).run() for b, k in ((False, "sah"), (True, "sah"), (True, "median"))]
    base = results[0]
    assert len(np.unique(base.ids)) >= 5
    for other in results[1:]:
        np.testing.assert_array_equal(other.path_ids, base.path_ids)
        np.testing.assert_allclose(other.image, base.image, atol=1e-5)
        np.testing.assert_allclose(other.shadow, base.shadow, atol=1e-6)
        assert other.node_visits < base.node_visits


def test_reflections_and_refractions_are_on_the_recorded_path(device):
    scene = mixed_scene()
    result = Renderer(scene).run()
    ids = result.path_ids
    # a mirror pixel's path continues to whatever the mirror shows: reflect the pixel's ray off the
    # mirror sphere here (r = d - 2 (d.n) n) and ask the closest-hit query what that ray meets
    o, d = pinhole_rays([0, 1, 6], [0, 0, 0])
    centre, radius = np.array([1.2, 0, -0.5]), 0.8
    oc = o - centre
    b = (oc * d).sum(-1)
    disc = b**2 - ((oc**2).sum(-1) - radius**2)
    mirror_pixels = (ids[..., 0] == 1) & (disc > 0.02)  # away from the silhouette
    assert mirror_pixels.sum() > 40
    t = -b[mirror_pixels] - np.sqrt(disc[mirror_pixels])
    p = o[mirror_pixels] + t[:, None] * d[mirror_pixels]
    n = (p - centre) / radius
    dm = d[mirror_pixels]
    reflected = dm - 2 * (dm * n).sum(-1, keepdims=True) * n
    _, _, expected = Tracer(scene).intersect(p + 1e-4 * n, reflected)
    seen = ids[mirror_pixels][:, 1]
    assert (seen == expected).mean() > 0.97
    assert len(set(expected[expected >= 0].tolist())) >= 2  # the mirror shows several objects
    glass_pixels = ids[..., 0] == 0
    # glass: the refracted ray leaves through the glass sphere itself (id 0) on its way out
    assert (ids[glass_pixels][:, 1:] == 0).any(axis=1).mean() > 0.9


def test_same_seed_same_image_different_seed_different(device):
    scene = mixed_scene()
    a = render(scene, aa="full", sampler="random", samples=2, seed=4)
    b = render(scene, aa="full", sampler="random", samples=2, seed=4)
    c = render(scene, aa="full", sampler="random", samples=2, seed=5)
    np.testing.assert_array_equal(a, b)
    assert np.abs(a - c).max() > 1e-3


def test_tile_size_does_not_change_the_image(device):
    scene = mixed_scene()
    a = render(scene, aa="full", sampler="stratified", samples=2, tile_size=7)
    b = render(scene, aa="full", sampler="stratified", samples=2, tile_size=200)
    np.testing.assert_array_equal(a, b)


@pytest.mark.parametrize("sampler", ["uniform", "stratified", "random"])
def test_edge_aa_equals_none_off_the_mask_and_full_on_it(device, sampler):
    scene = mixed_scene()
    common = dict(sampler=sampler, samples=3, seed=9, thickness=1.0)
    edge = Renderer(scene, aa="edge_detect", **common).run()
    none = render(scene, aa="none", **common)
    full = render(scene, aa="full", **common)
    mask = edge.edge_mask
    assert 0.02 < mask.mean() < 0.9
    np.testing.assert_array_equal(edge.image[~mask], none[~mask])
    np.testing.assert_array_equal(edge.image[mask], full[mask])


@pytest.mark.parametrize("smooth", [False, True])
def test_flat_meshes_report_facets_and_smooth_ones_do_not(device, smooth):
    scene = Scene.from_dict(
        {
            "width": 40,
            "height": 40,
            "cameras": [{"position": [0, 0, 3]}],
            "objects": [{"type": "mesh", "generator": "dense", "params": {"n_triangles": 200}, "smooth": smooth}],
        }
    )
    scene.cameras[0] = scene.cameras[0].__class__(position=(0, 0, 3), look_at=(0, 0, 0))
    result = Renderer(scene).run()
    on_mesh = result.ids == 0
    assert on_mesh.mean() > 0.3
    if smooth:
        assert (result.facets == -1).all()
    else:
        facets = result.facets[on_mesh]
        assert (facets >= 0).all() and len(np.unique(facets)) > 20
        # and the edge-AA mask follows the face boundaries
        edge = Renderer(scene, aa="edge_detect", thickness=0, shadow_edges=False).run()
        assert edge.edge_mask[on_mesh].mean() > 0.2


def test_pixel_filters_weight_samples_but_keep_flat_regions(device):
    scene = mixed_scene()
    box = render(scene, aa="full", samples=3, sampler="stratified", seed=2)
    for name in ("tent", "gaussian"):
        other = render(scene, aa="full", samples=3, sampler="stratified", seed=2, pixel_filter=name)
        assert np.abs(other - box).max() > 1e-3  # a different weighting near edges
        # (which weighting: test_outputs.py checks each against its formula, in the kernel and in a render)
        flat = render(scene, aa="full", samples=3, sampler="uniform", pixel_filter=name, width=8, height=6)
        # a weighted mean of equal values is that value: the background stays exact
        np.testing.assert_allclose(flat[0, 0], scene.background, rtol=1e-6)
