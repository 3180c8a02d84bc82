"""Exact ray queries (issue 12): axis-aligned rays through the BVH, watertight meshes, scale-invariant
surface offsets, a traversal stack that never drops a node, t_min and ties, physical light units.

Every answer is checked against an independent one: the analytic distance, the same query with the
BVH off, or a float64 reference computed here with numpy.
"""
import numpy as np
import pytest
import trimesh

from clrender.renderer import Renderer
from clrender.scene import Scene
from clrender.tracer import Tracer

AXES = np.eye(3)


# ------------------------------------------------------------------ 1. slab test, every direction
def test_issue_reproducer_one_triangle_straight_down(device):
    tri = (np.array([[-1.0, -1, 0], [1, -1, 0], [0, 1, 0]]), np.array([[0, 1, 2]]))
    for use_bvh in (False, True):
        t, prim, _ = Tracer(tri, use_bvh=use_bvh, device=device).intersect([[-0.25, -0.5, 5]], [[0, 0, -1]])
        assert t[0] == 5.0 and prim[0] == 0, use_bvh


def axis_rays(rng, n, half_width):
    """n rays along each of +x, -x, +y, -y, +z, -z (with +0 and -0 in the other components), starting
    at distance 5 on either side of the origin, offset sideways by up to half_width."""
    origins, directions = [], []
    for axis in range(3):
        for sign in (1.0, -1.0):
            d = np.zeros((n, 3))
            d[:, axis] = sign
            others = [a for a in range(3) if a != axis]
            d[n // 2:, others] = -0.0  # negative zeros: 1/d is -inf there
            o = np.zeros((n, 3))
            o[:, others] = rng.uniform(-half_width, half_width, (n, 2))
            o[:, axis] = np.where(np.arange(n) % 2 == 0, -5.0, 5.0)  # in front of the object, or past it
            origins.append(o)
            directions.append(d)
    return np.concatenate(origins), np.concatenate(directions)


def test_axis_rays_hit_a_cube_at_the_analytic_distance(device, rng):
    cube = trimesh.creation.box(extents=(2, 2, 2))
    o, d = axis_rays(rng, 64, 1.5)
    along = (o * d).sum(1)  # signed position of the origin along the ray's axis
    side = np.abs(o).max(1, where=d == 0, initial=0)  # how far off-axis the ray runs
    inside = side < 1
    expected = np.where(inside & (along < 0), -along - 1, np.inf)  # enters at the face 1 from the centre
    clear = np.abs(side - 1) > 1e-3  # rays along a face's edge could go either way
    for builder in ("sah", "median"):
        t, _, _ = Tracer(cube, builder=builder, device=device).intersect(o, d)
        np.testing.assert_array_equal(t[clear], expected[clear].astype(np.float32))
    t_flat, _, _ = Tracer(cube, use_bvh=False, device=device).intersect(o, d)
    np.testing.assert_array_equal(t_flat[clear], expected[clear].astype(np.float32))


@pytest.mark.parametrize("builder", ["sah", "median"])
def test_axis_rays_agree_with_and_without_the_bvh(device, rng, builder):
    mesh = trimesh.creation.icosphere(subdivisions=3)
    o, d = axis_rays(rng, 200, 1.1)
    t_ref, p_ref, _ = Tracer(mesh, use_bvh=False, device=device).intersect(o, d)
    t, p, _ = Tracer(mesh, builder=builder, device=device).intersect(o, d)
    assert np.isfinite(t_ref).sum() > 300
    np.testing.assert_array_equal(t, t_ref)
    np.testing.assert_array_equal(p, p_ref)
    blocked_ref = Tracer(mesh, use_bvh=False, device=device).occluded(o, d, 100.0)
    np.testing.assert_array_equal(Tracer(mesh, builder=builder, device=device).occluded(o, d, 100.0), blocked_ref)
    np.testing.assert_array_equal(blocked_ref, np.isfinite(t_ref))


def test_rays_in_a_boxs_face_plane_still_find_the_face(device):
    # a flat mesh in the plane z = 0 and rays that run inside that plane: 0 * inf in the slab test
    quad = (np.array([[0.0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]]), np.array([[0, 1, 2], [0, 2, 3]]))
    o = np.array([[-1.0, 0.5, 0], [2, 0.5, 0], [0.5, -1, 0]])
    d = np.array([[1.0, 0, 0], [-1, 0, 0], [0, 1, 0]])
    blocked = [Tracer(quad, use_bvh=b, device=device).occluded(o, d, 10.0) for b in (False, True)]
    np.testing.assert_array_equal(blocked[0], blocked[1])


def sphere_over_floor(light, size=40, extra=()):
    return Scene.from_dict({
        "width": size, "height": size,
        "cameras": [dict(position=[0, 4, 6], look_at=[0, 0, 0], up=[0, 1, 0], fov=45)],
        "materials": {"white": {"diffuse": [0.8, 0.8, 0.8], "specular": [0, 0, 0]}},
        "lights": [light],
        "objects": [{"type": "quad", "corner": [-5, 0, 5], "edge_a": [10, 0, 0], "edge_b": [0, 0, -10],
                     "material": "white"},
                    {"type": "sphere", "center": [0, 1, 0], "radius": 0.8, "material": "white"}, *extra],
    })


def test_light_straight_down_casts_the_whole_shadow_with_the_bvh(device):
    scene = sphere_over_floor({"type": "directional", "direction": [0, -1, 0]})
    results = {bvh: Renderer(scene, bvh=bvh).run() for bvh in (False, True)}
    # analytic: a floor pixel is in shadow iff its floor point lies within the sphere's radius of its foot
    o, d = scene.cameras[0].rays(40, 40)
    p = o + (-o[..., 1] / d[..., 1])[..., None] * d
    in_disc = np.hypot(p[..., 0], p[..., 2])
    floor = results[False].ids == 0
    clear = floor & (np.abs(in_disc - 0.8) > 0.05)
    for bvh, result in results.items():
        shadowed = result.shadow[..., 0] < 0.5
        np.testing.assert_array_equal(shadowed[clear], (in_disc < 0.8)[clear], err_msg=f"bvh={bvh}")
    assert (clear & (in_disc < 0.8)).sum() > 20
    np.testing.assert_array_equal(results[True].shadow, results[False].shadow)
