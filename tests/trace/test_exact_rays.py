"""Exact ray queries (issue 12): axis-aligned rays through the BVH, watertight meshes, scale-invariant
surface offsets, a traversal stack that never drops a node, t_min and ties, physical light units.

Every answer is checked against an independent one: the analytic distance, the same query with the
BVH off, or a float64 reference computed here with numpy.
"""

import warnings

import numpy as np
import pytest
import trimesh

from clrender.scene.scene import Scene
from clrender.trace.knobs import DEFAULT_KNOBS, TraceKnobs
from clrender.trace.renderer import Renderer
from clrender.trace.tracer import Tracer

from tests.meshtools import degenerate_meshes, grid_mesh, rays_at_triangles, triangles_containing

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
            d[n // 2 :, others] = -0.0  # negative zeros: 1/d is -inf there
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


def test_axis_aligned_camera_sees_no_background_through_objects(device):
    # odd image sizes: the centre row and column have exactly zero direction components
    mesh = {"type": "mesh", "generator": "dense", "params": {"n_triangles": 2000, "seed": 3}}
    scene = Scene.from_dict(
        {"width": 33, "height": 33, "objects": [mesh], "cameras": [dict(position=[-0.3, -0.2, 6], look_at=[-0.3, -0.2, 0], up=[0, 1, 0], fov=40)]}
    )
    ids = {bvh: Renderer(scene, bvh=bvh).run().ids for bvh in (False, True)}
    assert (ids[False][16, 12:21] == 0).all() and (ids[False][12:21, 16] == 0).all()  # the mesh fills the centre
    np.testing.assert_array_equal(ids[True], ids[False])


def sphere_over_floor(light, size=40, extra=()):
    return Scene.from_dict(
        {
            "width": size,
            "height": size,
            "cameras": [dict(position=[0, 4, 6], look_at=[0, 0, 0], up=[0, 1, 0], fov=45)],
            "materials": {"white": {"diffuse": [0.8, 0.8, 0.8], "specular": [0, 0, 0]}},
            "lights": [light],
            "objects": [
                {"type": "quad", "corner": [-5, 0, 5], "edge_a": [10, 0, 0], "edge_b": [0, 0, -10], "material": "white"},
                {"type": "sphere", "center": [0, 1, 0], "radius": 0.8, "material": "white"},
                *extra,
            ],
        }
    )


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


# ------------------------------------------------------------------ 2. watertight triangles
def shared_edge_rays(mesh, rng, n, distance):
    """n rays aimed at random points of edges shared by two triangles of a closed convex mesh, from
    `distance` mesh diagonals away, on the side both triangles face."""
    edges = mesh.face_adjacency_edges
    pick = rng.integers(0, len(edges), n)
    s = rng.uniform(0.05, 0.95, n)[:, None]
    target = mesh.vertices[edges[pick, 0]] * (1 - s) + mesh.vertices[edges[pick, 1]] * s
    normals = mesh.face_normals[mesh.face_adjacency[pick]]  # (n, 2, 3)
    outward = normals.sum(1)
    outward /= np.linalg.norm(outward, axis=1, keepdims=True)
    tilt = rng.normal(size=(n, 3)) * 0.3
    away = outward + tilt - (tilt * outward).sum(1, keepdims=True) * outward
    away /= np.linalg.norm(away, axis=1, keepdims=True)
    facing_both = (np.einsum("nij,nj->ni", normals, away) > 0.05).all(1)
    origin = target + away * distance * np.linalg.norm(mesh.extents)
    d = target - origin
    return (
        origin[facing_both],
        d[facing_both] / np.linalg.norm(d[facing_both], axis=1, keepdims=True),
        np.linalg.norm(target - origin, axis=1)[facing_both],
    )


@pytest.mark.parametrize("distance", [0.05, 1.0, 20.0, 1000.0])
def test_rays_at_shared_edges_never_pass_between_the_triangles(device, distance):
    mesh = trimesh.creation.icosphere(subdivisions=2)
    mesh.apply_transform(trimesh.transformations.random_rotation_matrix(np.random.default_rng(7).random(3)))
    o, d, expected = shared_edge_rays(mesh, np.random.default_rng(8), 3000, distance)
    assert len(o) > 2000
    for use_bvh in (False, True):
        t, _, _ = Tracer(mesh, use_bvh=use_bvh, device=device).intersect(o, d)
        # a ray through a crack meets the far side of the sphere (radius 1) instead, or nothing
        fell_through = ~(np.abs(t - expected) <= 0.05)
        assert fell_through.sum() == 0, (use_bvh, int(fell_through.sum()), len(t))


def test_watertight_hits_agree_with_embree(device):
    embree = pytest.importorskip("embreex.rtcore_scene")
    from embreex.mesh_construction import TriangleMesh

    mesh = trimesh.creation.icosphere(subdivisions=2)
    o, d, _ = shared_edge_rays(mesh, np.random.default_rng(9), 2000, 20.0)
    scene = embree.EmbreeScene()
    TriangleMesh(scene, np.asarray(mesh.vertices, np.float32)[np.asarray(mesh.faces)])
    t_embree = scene.run(o.astype(np.float32), d.astype(np.float32), output=1)["tfar"]
    t, _, _ = Tracer(mesh, device=device).intersect(o, d)
    assert np.isfinite(t_embree).all() and np.isfinite(t).all()
    np.testing.assert_allclose(t, t_embree, rtol=1e-5)


def exact_side(p, q):
    """Sign of the 2D cross product p x q = px qy - py qx of float32 points, in exact rational arithmetic."""
    from fractions import Fraction

    px, py, qx, qy = (Fraction(float(c)) for c in (*p, *q))
    return (px * qy - py * qx > 0) - (px * qy - py * qx < 0)


@pytest.mark.parametrize(("scale", "offset"), [(1.0, (0.0, 0.0)), (2.0**20, (0.0, 0.0)), (2.0**-20, (0.0, 0.0)), (1.0, (1024.0, -512.0))])
def test_edge_functions_within_their_rounding_error_take_the_exact_sign(device, scale, offset):
    """Two triangles share the edge v1 v2 = (1 + 2^-12, 1 + 2^-11) to (-1, -1 - 2^-12), whose line
    misses a +z ray through the origin by 2^-24 / |v1 - v2|: the edge function v1x v2y - v1y v2x is
    exactly -2^-24 (times scale^2), but both products round to 1 + 2^-11, so the plain float32 difference
    is 0, "on the edge".  Only the exactly recomputed value puts the ray on one side: it meets triangle
    1 and passes triangle 0 by, where with a plain 0 it would meet both (and the tie would give it 0)."""
    v1, v2 = np.array([1 + 2.0**-12, 1 + 2.0**-11]), np.array([-1.0, -(1 + 2.0**-12)])
    apex = np.array([[1.0, -1.0], [-1.0, 1.0]])  # triangle 0 on the ray's far side of the edge, 1 on its side
    shift = np.array(offset)
    xy = np.concatenate([apex[:1], [v1, v2], apex[1:]]) * scale + shift
    vertices = np.column_stack([xy, np.zeros(4)])
    assert (vertices.astype(np.float32) == vertices).all()
    faces = np.array([[0, 1, 2], [3, 1, 2]])
    origin, direction = np.array([[*shift, -1.0]]), np.array([[0.0, 0.0, 1.0]])
    # what the kernel sees: vertices minus the ray origin (exact here) in float32
    q = (vertices[:, :2] - shift).astype(np.float32)
    assert (q.astype(np.float64) == xy - shift).all()
    a, b = q[1, 0] * q[2, 1], q[1, 1] * q[2, 0]  # numpy rounds each float32 product, no fma
    assert a - b == 0 and exact_side(q[1], q[2]) == -1  # the plain difference is 0, the exact one negative
    # the reference: inside where the exact edge functions (v1 v2, v2 apex, apex v1) agree in sign
    sides = [[exact_side(q[f[1]], q[f[2]]), exact_side(q[f[2]], q[f[0]]), exact_side(q[f[0]], q[f[1]])] for f in faces]
    inside = [min(s) >= 0 or max(s) <= 0 for s in sides]
    assert inside == [False, True]
    for use_bvh in (False, True):
        tracer = Tracer((vertices, faces), use_bvh=use_bvh, device=device)
        t, prim, _ = tracer.intersect(origin, direction)
        assert (t[0], prim[0]) == (1.0, 1), use_bvh
        alone = Tracer((vertices, faces[:1]), use_bvh=use_bvh, device=device)  # triangle 0 alone: missed
        t, prim, _ = alone.intersect(origin, direction)
        assert (t[0], prim[0]) == (np.inf, -1), use_bvh
        assert not alone.occluded(origin, direction, [2.0])[0], use_bvh
        assert tracer.occluded(origin, direction, [2.0])[0], use_bvh


# ------------------------------------------------------------------ 3. offsets at every scale and position
CARD_Y, SPHERE_GAP = 0.05, 0.002  # a card 0.05 above the floor; a sphere 0.002 above it
SPHERES = [((2.2, 0.5 + SPHERE_GAP, -1.0), 0.5), ((-2.2, 0.6, 1.5), 0.6)]  # the second rests on the floor
LIGHT_AT = np.array([0.3, 5.0, 0.2])
# camera 1 sees the whole scene; camera 2 sits in the gap beside the card, looking under it
CAMS = [dict(position=[0, 5, 7], look_at=[0, 0, 0], fov=40), dict(position=[1.3, 0.045, 0.1], look_at=[0.3, 0, 0], fov=50)]


def contact_scene(scale, shift, size):
    at = lambda x: (np.asarray(x, float) * scale + shift).tolist()
    length = lambda x: (np.asarray(x, float) * scale).tolist()
    quad = lambda corner, a, b: {"type": "quad", "corner": at(corner), "edge_a": length(a), "edge_b": length(b), "material": "white"}
    return Scene.from_dict(
        {
            "width": size,
            "height": size,
            "cameras": [dict(position=at(c["position"]), look_at=at(c["look_at"]), up=[0, 1, 0], fov=c["fov"]) for c in CAMS],
            "materials": {"white": {"diffuse": [0.8, 0.8, 0.8], "specular": [0, 0, 0]}},
            "lights": [{"type": "point", "position": at(LIGHT_AT)}],
            "objects": [
                quad([-4, 0, 4], [8, 0, 0], [0, 0, -8]),
                quad([-1, CARD_Y, 1], [2, 0, 0], [0, 0, -2]),
                *({"type": "sphere", "center": at(c), "radius": r * scale, "material": "white"} for c, r in SPHERES),
            ],
        }
    )


def first_hits(o, d):
    """float64 reference at unit scale: object id, hit point and outward normal of each ray."""
    n = len(o)
    t_best, ids, normal = np.full(n, np.inf), np.full(n, -1), np.zeros((n, 3))
    for oid, (y, half) in enumerate([(0.0, 4.0), (CARD_Y, 1.0)]):
        with np.errstate(divide="ignore", invalid="ignore"):
            t = (y - o[:, 1]) / d[:, 1]
            p = o + t[:, None] * d
        ok = (t > 1e-9) & (np.abs(p[:, 0]) <= half) & (np.abs(p[:, 2]) <= half) & (t < t_best)
        t_best[ok], ids[ok], normal[ok] = t[ok], oid, np.sign(-d[ok, 1])[:, None] * [0, 1, 0]
    for k, (c, r) in enumerate(SPHERES):
        oc = o - c
        b = (oc * d).sum(1)
        disc = b * b - ((oc * oc).sum(1) - r * r)
        t = -b - np.sqrt(np.maximum(disc, 0))
        ok = (disc > 0) & (t > 1e-9) & (t < t_best)
        t_best[ok], ids[ok] = t[ok], 2 + k
        normal[ok] = (o[ok] + t[ok, None] * d[ok] - c) / r
    return ids, o + np.where(np.isfinite(t_best), t_best, 0)[:, None] * d, normal


def reference_buffers(scene, camera, size, offset):
    """Object id and light visibility at each pixel's first hit (1 where the surface faces away)."""
    o, d = scene.cameras[camera].rays(size, size, offset)
    o, d = o.reshape(-1, 3).astype(float), d.reshape(-1, 3).astype(float)
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    ids, p, n = first_hits(o, d)
    to_light = LIGHT_AT - p
    dist = np.linalg.norm(to_light, axis=1)
    to_light /= dist[:, None]
    blocker, _, _ = first_hits(p + 1e-9 * n, to_light)
    _, q, _ = first_hits(p + 1e-9 * n, to_light)
    blocked = (blocker >= 0) & (np.linalg.norm(q - p, axis=1) < dist)
    visible = np.where(((n * to_light).sum(1) <= 0) | ~blocked, 1.0, 0.0)
    visible[ids < 0] = 1.0
    return ids.reshape(size, size), visible.reshape(size, size)


@pytest.mark.parametrize("camera", [1, 2])
@pytest.mark.parametrize("scale, shift", [(1e-3, 0.0), (1.0, 0.0), (1e3, 0.0), (1.0, 1e3)])
def test_near_contact_shadows_are_the_same_at_every_scale_and_position(device, scale, shift, camera):
    size = 40
    ref = [
        reference_buffers(contact_scene(1.0, 0.0, size), camera - 1, size, off)
        for off in [(0.5, 0.5), (0.2, 0.2), (0.8, 0.2), (0.2, 0.8), (0.8, 0.8)]
    ]
    ids_ref, vis_ref = ref[0]
    # pixels whose whole footprint agrees: no id or shadow boundary runs through them
    clear = np.all([(i == ids_ref) & (v == vis_ref) for i, v in ref], axis=0)
    assert clear.mean() > 0.8
    shadowed_floor = (ids_ref == 0) & (vis_ref == 0) & clear
    assert shadowed_floor.sum() > 10  # under the card (camera 2) or the spheres (camera 1)
    result = Renderer(contact_scene(scale, shift, size), camera=camera).run()
    np.testing.assert_array_equal(result.ids[clear], ids_ref[clear])
    # shadowed where the reference is, and lit exactly (no acne) where it is lit
    np.testing.assert_array_equal(result.shadow[..., 0][clear], vis_ref[clear])


# ------------------------------------------------------------------ 4. the traversal stack never drops a node
@pytest.mark.parametrize("stack_size", [None, 2])
def test_degenerate_meshes_find_every_primitive_the_brute_force_finds(device, stack_size):
    """Every builder against no BVH; with stack_size=2 the kernels' stack overflows on purpose and their
    fallback must still give the brute-force answers."""
    knobs = DEFAULT_KNOBS if stack_size is None else TraceKnobs(stack_size=stack_size)
    rng = np.random.default_rng(21)
    for name, vertices in degenerate_meshes(rng):
        mesh = (vertices, np.arange(len(vertices)).reshape(-1, 3))
        o, d = rays_at_triangles(rng, vertices, 500)
        flat = Tracer(mesh, use_bvh=False, device=device)
        t_ref, p_ref, _ = flat.intersect(o, d)
        blocked_ref = flat.occluded(o, d, 40.0)
        assert np.isfinite(t_ref).mean() > 0.9, name
        for builder in ("sah", "median"):
            tracer = Tracer(mesh, builder=builder, device=device, knobs=knobs)
            assert tracer.bvh.depth <= knobs.max_tree_levels
            t, p, _ = tracer.intersect(o, d)
            np.testing.assert_array_equal(t, t_ref, err_msg=f"{name} {builder}")
            np.testing.assert_array_equal(p, p_ref, err_msg=f"{name} {builder}")
            np.testing.assert_array_equal(tracer.occluded(o, d, 40.0), blocked_ref, err_msg=f"{name} {builder}")


# ------------------------------------------------------------------ 5. t_min, units of t, ties
def two_planes():
    """Squares at z = -1 (ids 0, 1) and z = -3 (ids 2, 3)."""
    v = np.array([[-1.0, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]])
    vertices = np.concatenate([v + [0, 0, -1], v + [0, 0, -3]])
    return vertices, np.array([[0, 1, 2], [0, 2, 3], [4, 5, 6], [4, 6, 7]])


@pytest.mark.parametrize("use_bvh", [False, True])
def test_t_min_skips_nearer_hits(device, use_bvh):
    tracer = Tracer(two_planes(), use_bvh=use_bvh, device=device)
    o = np.tile([0.3, -0.2, 0.0], (4, 1))
    d = np.tile([0.0, 0.0, -1.0], (4, 1))
    t, prim, _ = tracer.intersect(o, d, t_min=[0.0, 0.5, 1.5, 3.5])
    np.testing.assert_array_equal(t, [1, 1, 3, np.inf])
    assert prim[0] in (0, 1) and prim[2] in (2, 3) and prim[3] == -1
    assert tracer.occluded(o, d, t_max=5.0, t_min=[0.0, 0.5, 1.5, 3.5]).tolist() == [True, True, True, False]
    # a ray leaving the first plane from a point on it: t_min (or an offset origin) is the caller's job
    on_surface = np.array([[0.3, -0.2, -1.0]])
    assert tracer.intersect(on_surface, [[0, 0, -1]], t_min=1e-4)[0][0] == 2.0


@pytest.mark.parametrize("use_bvh", [False, True])
def test_t_is_in_units_of_the_direction_as_given(device, use_bvh):
    scene = Scene.from_dict(
        {
            "objects": [
                {"type": "sphere", "center": [4, 0, -5], "radius": 1},
                {"type": "triangle", "vertices": [[-1, -1, -4], [1, -1, -4], [0, 1, -4]]},
            ]
        }
    )
    tracer = Tracer(scene, use_bvh=use_bvh, device=device)
    o = np.array([[0.0, 0, 0], [0, 0, 0], [4, 0, 0]])
    d = np.array([[0.0, 0, -2], [0, 0, -0.5], [0, 0, -8]])
    t, prim, _ = tracer.intersect(o, d)
    np.testing.assert_allclose(t, [2.0, 8.0, 0.5], rtol=1e-6)  # hits at z = -4, -4 and -4 (the sphere's front)
    assert tracer.occluded(o, d, t_max=[1.9, 8.1, 0.49]).tolist() == [False, True, False]


@pytest.mark.parametrize("layout", [dict(use_bvh=False), dict(bvh_width=2), dict(bvh_width=8, ray_packets=False), dict(bvh_width=8)])
def test_directions_of_any_magnitude_give_t_in_their_units(device, layout):
    """|d| from 1e-37 to 3e38 (t up to 4e37: within float32): its square over- or underflows float32 beyond about 1e19 and 1e-19,
    but t * |d| is still the distance to the triangle 4 ahead, and t_max (in the same units) still
    decides occlusion; eight rays per scale, so they also go as one packet."""
    triangle = (np.array([[-1.0, -1.0, -4.0], [1.0, -1.0, -4.0], [0.0, 1.0, -4.0]]), np.array([[0, 1, 2]]))
    tracer = Tracer(triangle, device=device, **layout)
    for scale in (1e-37, 1e-30, 2.0**-70, 1e-19, 1.0, 1e19, 2.0**70, 1e30, 3e38):
        d = np.tile([0.0, 0.0, -scale], (8, 1)) + np.linspace(0, 0.01 * scale, 8)[:, None] * [1, 0, 0]
        o = np.zeros((8, 3))
        t, prim, _ = tracer.intersect(o, d)
        distance = 4.0 * np.linalg.norm(d / scale, axis=1)  # the hit is at z = -4
        np.testing.assert_allclose(t * np.linalg.norm(d, axis=1), distance, rtol=1e-6, err_msg=f"|d| = {scale}")
        assert (prim == 0).all()
        assert tracer.occluded(o, d, t_max=1.01 * t.astype(np.float64)).all()
        assert not tracer.occluded(o, d, t_max=0.99 * t.astype(np.float64)).any()


def test_ties_at_shared_edges_and_vertices_go_to_the_lowest_id(device):
    vertices, faces = grid_mesh(8)
    # straight down at every vertex and every edge midpoint of the interior (exact in float32)
    pts = np.array([[x / 2, y / 2] for x in range(2, 15) for y in range(2, 15)])
    o = np.c_[pts, np.full(len(pts), 5.0)]
    d = np.tile([0.0, 0.0, -1.0], (len(pts), 1))
    # reference: the lowest id among the triangles whose closed area contains the point
    contains = triangles_containing(vertices, faces, pts)
    expected = np.argmax(contains, axis=0)
    assert contains.sum(0).max() >= 6  # some points lie on six triangles
    for use_bvh, builder in ((False, "sah"), (True, "sah"), (True, "median")):
        t, prim, _ = Tracer((vertices, faces), use_bvh=use_bvh, builder=builder, device=device).intersect(o, d)
        np.testing.assert_array_equal(t, 5.0)
        np.testing.assert_array_equal(prim, expected, err_msg=f"bvh={use_bvh} {builder}")


def test_bad_rays_are_refused(device):
    from clrender.errors import UsageError

    tracer = Tracer(two_planes(), device=device)
    with pytest.raises(UsageError, match="nonzero"):
        tracer.intersect([[0, 0, 0]], [[0, 0, 0]])
    with pytest.raises(UsageError, match="t_min"):
        tracer.intersect([[0, 0, 0]], [[0, 0, 1]], t_min=[0, 1])
    with pytest.raises(UsageError, match="finite"):  # beyond float32: refused, not a numpy warning
        tracer.intersect([[1e39, 0, 0]], [[0, 0, -1]])


def test_distances_beyond_float32_count_as_infinite(device):
    """t_min or t_max past float32's range is infinity to a float32 tracer: no hit beyond it, every
    surface before it; and no numpy overflow warning on the way."""
    tracer = Tracer(two_planes(), device=device)
    o, d = np.tile([0.3, -0.2, 0.0], (8, 1)), np.tile([0.0, 0.0, -1.0], (8, 1))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert np.isinf(tracer.intersect(o, d, t_min=3.5e38)[0]).all()
        assert tracer.occluded(o, d, t_max=1e39).all()


# ------------------------------------------------------------------ 6. physical light units
FLOOR_CAM = dict(position=[0, 3, 2.5], look_at=[0, 0, 0], up=[0, 1, 0], fov=50)


def lit_floor(light, material, size=20):
    return Scene.from_dict(
        {
            "width": size,
            "height": size,
            "cameras": [FLOOR_CAM],
            "materials": {"m": material},
            "lights": [light],
            "objects": [{"type": "quad", "corner": [-6, 0, 6], "edge_a": [12, 0, 0], "edge_b": [0, 0, -12], "material": "m"}],
        }
    )


def floor_hits(scene, size):
    o, d = scene.cameras[0].rays(size, size)
    t = -o[..., 1] / d[..., 1]
    return o + t[..., None] * d, o


def polygon_irradiance(points, corners, radiance):
    """Lambert's formula: irradiance on the plane y = 0 (normal +y) from a uniform polygon of this radiance."""
    total = np.zeros(points.shape[:-1])
    for k in range(len(corners)):
        u = corners[k] - points
        w = corners[(k + 1) % len(corners)] - points
        u /= np.linalg.norm(u, axis=-1, keepdims=True)
        w /= np.linalg.norm(w, axis=-1, keepdims=True)
        cr = np.cross(u, w)
        total += np.arccos(np.clip((u * w).sum(-1), -1, 1)) * cr[..., 1] / np.linalg.norm(cr, axis=-1)
    return radiance * np.abs(total) / 2


def test_physical_diffuse_radiance_is_kd_over_pi_times_lamberts_irradiance(device):
    light = dict(type="area", corner=[-0.5, 1.5, -0.5], edge_a=[1, 0, 0], edge_b=[0, 0, 1], intensity=3.0, falloff="inverse_square")
    kd = 0.6
    scene = lit_floor(light, {"diffuse": [kd] * 3, "specular": [0, 0, 0]})
    image = Renderer(scene, light_samples=32, seed=4).run().image[..., 0]
    p, _ = floor_hits(scene, 20)
    c, a, b = (np.array(light[k], float) for k in ("corner", "edge_a", "edge_b"))
    expected = kd / np.pi * polygon_irradiance(p, [c, c + a, c + a + b, c + b], light["intensity"])
    assert expected.min() > 0.002 and expected.max() > 0.05
    np.testing.assert_allclose(image, expected, rtol=0.01)


def test_physical_point_light_uses_normalised_blinn_phong(device):
    light = dict(type="point", position=[0.4, 1.2, 0.3], intensity=4.0, falloff="inverse_square")
    kd, ks, s = 0.5, 0.4, 20.0
    scene = lit_floor(light, {"diffuse": [kd] * 3, "specular": [ks] * 3, "shininess": s})
    image = Renderer(scene).run().image[..., 0]
    p, eye = floor_hits(scene, 20)
    to_light, to_eye = light["position"] - p, eye - p
    r = np.linalg.norm(to_light, axis=-1)
    l, v = to_light / r[..., None], to_eye / np.linalg.norm(to_eye, axis=-1, keepdims=True)
    h = (l + v) / np.linalg.norm(l + v, axis=-1, keepdims=True)
    brdf = kd / np.pi + ks * (s + 8) / (8 * np.pi) * h[..., 1] ** s  # the floor's normal is +y
    expected = brdf * light["intensity"] * l[..., 1] / r**2
    assert (ks * (s + 8) / (8 * np.pi) * h[..., 1] ** s > kd / np.pi).any()  # the highlight is in view
    np.testing.assert_allclose(image, expected, rtol=2e-3)


def test_the_seeds_model_stays_the_default(device):
    light = dict(type="point", position=[0.4, 1.2, 0.3], intensity=4.0)
    kd = 0.5
    scene = lit_floor(light, {"diffuse": [kd] * 3, "specular": [0, 0, 0]})
    image = Renderer(scene).run().image[..., 0]
    p, _ = floor_hits(scene, 20)
    to_light = light["position"] - p
    np.testing.assert_allclose(
        image, kd * light["intensity"] * to_light[..., 1] / np.linalg.norm(to_light, axis=-1), rtol=1e-4
    )  # kd I cos(theta): no 1/pi, no falloff
