"""Ray-primitive intersection through the Tracer API, against analytic and numpy references."""

import numpy as np
import pytest

from clrender.scene.scene import Scene
from clrender.trace.tracer import Tracer


def sphere_scene(center=(0, 0, -5), radius=1.0):
    return Scene.from_dict({"objects": [{"type": "sphere", "center": list(center), "radius": radius}]})


def test_ray_hits_sphere_at_analytic_distance(device):
    tracer = Tracer(sphere_scene(), use_bvh=False, device=device)
    # rays from the origin towards points of the sphere's disc: t = b - sqrt(b^2 - c)
    rng = np.random.default_rng(1)
    targets = np.c_[rng.uniform(-0.9, 0.9, (200, 2)) * 0.7, np.full(200, -5.0)]
    d = targets / np.linalg.norm(targets, axis=1, keepdims=True)
    oc = -np.array([0, 0, -5.0])
    b = -(d @ oc)
    expected = b - np.sqrt(b * b - (oc @ oc - 1.0))
    t, prim, obj = tracer.intersect(np.zeros_like(d), d)
    np.testing.assert_allclose(t, expected, rtol=2e-6)
    assert (prim == 0).all() and (obj == 0).all()


def test_ray_from_inside_sphere_hits_far_side(device):
    tracer = Tracer(sphere_scene((0, 0, 0), 2.0), use_bvh=False, device=device)
    rng = np.random.default_rng(2)
    d = rng.normal(size=(100, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    t, prim, _ = tracer.intersect(np.zeros_like(d), d)
    np.testing.assert_allclose(t, 2.0, rtol=1e-6)


def test_grazing_rays_hit_only_within_the_radius(device):
    tracer = Tracer(sphere_scene((0, 0, -5), 1.0), use_bvh=False, device=device)
    # parallel rays offset in x: inside the radius they hit, outside they miss
    x = np.array([0.999, 0.9999, 1.0001, 1.001])
    o = np.c_[x, np.zeros(4), np.zeros(4)]
    d = np.tile([0.0, 0.0, -1.0], (4, 1))
    t, prim, _ = tracer.intersect(o, d)
    assert np.isfinite(t[:2]).all() and (prim[:2] == 0).all()
    np.testing.assert_allclose(t[:2], 5.0 - np.sqrt(1 - x[:2] ** 2), atol=2e-4)
    assert np.isinf(t[2:]).all() and (prim[2:] == -1).all()


def moller_trumbore(o, d, v0, v1, v2):
    """float64 reference: t or inf for each ray against one triangle."""
    e1, e2 = v1 - v0, v2 - v0
    p = np.cross(d, e2)
    det = p @ e1
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = 1.0 / det
        s = o - v0
        u = np.einsum("ij,ij->i", s, p) * inv
        q = np.cross(s, e1)
        v = np.einsum("ij,ij->i", d, q) * inv
        t = (q @ e2) * inv
    hit = (det != 0) & (u >= 0) & (v >= 0) & (u + v <= 1) & (t > 0)
    return np.where(hit, t, np.inf)


def test_triangle_hits_match_float64_reference(device):
    v = np.array([[-1.0, -1, -4], [2, -0.5, -5], [0, 1.5, -3]])
    tracer = Tracer((v, np.array([[0, 1, 2]])), use_bvh=False, device=device)
    rng = np.random.default_rng(3)
    d = np.c_[rng.uniform(-0.6, 0.6, (2000, 2)), -np.ones(2000)]
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    o = np.zeros_like(d)
    expected = moller_trumbore(o, d, *v)
    t, prim, _ = tracer.intersect(o, d)
    # away from the edges (where float32 and float64 may disagree) hits and misses agree
    close_to_edge = np.abs(np.isfinite(t).astype(int) - np.isfinite(expected).astype(int)) > 0
    assert close_to_edge.mean() < 0.002
    both = np.isfinite(t) & np.isfinite(expected)
    assert both.sum() > 200
    np.testing.assert_allclose(t[both], expected[both], rtol=1e-5)


def test_degenerate_triangles_are_never_hit(device):
    v = np.array([[0.0, 0, -2], [1, 1, -2], [2, 2, -2], [0, 0, -3], [0, 0, -3], [1, 0, -3]])
    faces = np.array([[0, 1, 2], [3, 4, 5]])  # collinear, and two equal vertices
    tracer = Tracer((v, faces), use_bvh=False, device=device)
    rng = np.random.default_rng(4)
    o = np.c_[rng.uniform(-0.5, 2.5, (500, 2)), np.zeros(500)]
    d = np.tile([0.0, 0.0, -1.0], (500, 1))
    t, prim, _ = tracer.intersect(o, d)
    assert (prim == -1).all()


def test_occluded_respects_t_max(device):
    tracer = Tracer(sphere_scene(), use_bvh=False, device=device)
    o = np.zeros((3, 3))
    d = np.tile([0.0, 0.0, -1.0], (3, 1))
    assert tracer.occluded(o, d, [3.9, 4.1, np.inf]).tolist() == [False, True, True]


@pytest.mark.parametrize("builder", ["sah", "median"])
def test_bvh_and_brute_force_find_the_same_hits(device, builder):
    rng = np.random.default_rng(5)
    centres = rng.uniform(-3, 3, (400, 3)) + [0, 0, -8]
    tris = centres[:, None, :] + rng.normal(scale=0.4, size=(400, 3, 3))
    spheres = [
        {"type": "sphere", "center": c.tolist(), "radius": float(r)}
        for c, r in zip(rng.uniform(-3, 3, (30, 3)) + [0, 0, -8], rng.uniform(0.1, 0.5, 30))
    ]
    scene = Scene.from_dict({"objects": spheres})
    from clrender.scene.scene import Mesh

    scene.objects.append(Mesh(tris.reshape(-1, 3), np.arange(1200).reshape(-1, 3)))
    o = rng.normal(scale=0.3, size=(5000, 3))
    d = np.c_[rng.uniform(-0.5, 0.5, (5000, 2)), -np.ones(5000)]
    brute = Tracer(scene, use_bvh=False, device=device).intersect(o, d)
    fast_tracer = Tracer(scene, use_bvh=True, builder=builder, device=device)
    fast = fast_tracer.intersect(o, d)
    np.testing.assert_array_equal(fast[1], brute[1])
    np.testing.assert_array_equal(fast[2], brute[2])
    np.testing.assert_array_equal(fast[0], brute[0])
    assert (fast[1] >= 0).mean() > 0.3
    # the BVH visits far fewer nodes than there are primitives
    assert fast_tracer.last_visits.mean() < 0.25 * 430
    t_max = rng.uniform(1, 12, 5000)
    np.testing.assert_array_equal(Tracer(scene, use_bvh=False, device=device).occluded(o, d, t_max), fast_tracer.occluded(o, d, t_max))


def test_no_cracks_along_an_edge_two_triangles_share(device):
    # a quad split along its diagonal; rays aimed exactly at the diagonal all hit
    v = np.array([[-1.0, -1, -3], [1, -1, -3.5], [1, 1, -3], [-1, 1, -2.5]])
    tracer = Tracer((v, np.array([[0, 1, 2], [0, 2, 3]])), use_bvh=False, device=device)
    s = np.linspace(0.001, 0.999, 20001)[:, None]
    targets = v[0] + s * (v[2] - v[0])
    origins = np.tile([0.05, 0.02, 0.0], (len(s), 1))
    t, prim, _ = tracer.intersect(origins, targets - origins)
    assert (prim >= 0).all()
