"""The wide BVHs (clrender/trace/bvh_wide.py, 4 and 8 lanes): the tree's invariants, and the same closest
hits and occlusion answers as the binary tree and as the BVH-off path (every ray tests every primitive)."""

import numpy as np
import pytest

from clrender.scene.meshes import dense_mesh
from clrender.trace.bvh import build_bvh, half_area
from clrender.trace.bvh_wide import collapse
from clrender.trace.knobs import DEFAULT_KNOBS, TraceKnobs
from clrender.trace.tracer import Tracer

from tests.meshtools import degenerate_meshes, rays_at_triangles


def triangle_bounds(vertices, faces):
    tri = np.asarray(vertices, np.float32)[np.asarray(faces)]
    return tri.min(1), tri.max(1)


def lane_boxes(wide, i):
    """(lo, hi) of the lanes of wide node i, each (width, 3)."""
    return wide.lo[i].T, wide.hi[i].T


def check_invariants(wide, lo, hi):
    n = len(lo)
    child, count = wide.child, wide.count
    # every primitive in exactly one leaf: the leaf lanes' slot ranges tile 0..n-1 once
    leaf = count > 0
    starts, counts = child[leaf], count[leaf]
    covered = np.zeros(n, np.int64)
    for s, c in zip(starts, counts):
        covered[s : s + c] += 1
    assert (covered == 1).all()
    assert np.array_equal(np.sort(wide.prim_order), np.arange(n))
    # every wide node but the root is the child of exactly one interior lane, and comes after it
    interior = count == 0
    parents = np.nonzero(interior)
    kids = child[interior]
    assert np.array_equal(np.sort(kids), np.arange(1, len(wide.nodes)))
    assert (kids > parents[0]).all()
    # bounds contain their children: interior lanes contain every valid lane of their node,
    # leaf lanes contain their primitives' boxes
    for (i, k), c in zip(zip(*parents), kids):
        plo, phi = lane_boxes(wide, i)
        clo, chi = lane_boxes(wide, c)
        valid = count[c] >= 0
        assert valid.any()
        assert (clo[valid] >= plo[k]).all() and (chi[valid] <= phi[k]).all()
    for i, k in zip(*np.nonzero(leaf)):
        prims = wide.prim_order[child[i, k] : child[i, k] + count[i, k]]
        blo, bhi = lane_boxes(wide, i)
        assert (lo[prims] >= blo[k]).all() and (hi[prims] <= bhi[k]).all()
    # empty lanes are inverted boxes, and a wide tree is no deeper than the binary one
    empty = count < 0
    assert (wide.lo.transpose(0, 2, 1)[empty] > wide.hi.transpose(0, 2, 1)[empty]).all()
    assert wide.depth <= wide.binary.depth


@pytest.mark.parametrize("width", [4, 8])
@pytest.mark.parametrize("builder", ["sah", "median"])
def test_wide_tree_holds_every_primitive_once_inside_bounds_that_contain_their_children(builder, width):
    mesh = dense_mesh(3000, seed=3)
    lo, hi = triangle_bounds(mesh.vertices, mesh.faces)
    wide = collapse(build_bvh(lo, hi, builder=builder), width)
    check_invariants(wide, lo, hi)
    # collapsing fills nodes: each wide node stands for at least two binary interior nodes on average
    assert wide.node_count < 0.5 * (wide.binary.node_count - wide.binary.leaf_count)


def test_wide_tree_invariants_on_degenerate_and_tiny_inputs():
    rng = np.random.default_rng(5)
    for _name, vertices in degenerate_meshes(rng):
        lo, hi = triangle_bounds(vertices, np.arange(len(vertices)).reshape(-1, 3))
        for width in (4, 8):
            check_invariants(collapse(build_bvh(lo, hi), width), lo, hi)
    for n in (1, 2, 3, 5, 9, 17):  # a lone leaf root, and trees of one to three levels
        lo = rng.uniform(-1, 0, (n, 3)).astype(np.float32)
        hi = lo + rng.uniform(0, 1, (n, 3)).astype(np.float32)
        for width in (4, 8):
            check_invariants(collapse(build_bvh(lo, hi, max_leaf_size=1), width), lo, hi)


def test_wide_sah_cost_counts_wide_nodes_and_the_same_leaves():
    """The wide tree tests the binary tree's leaves behind fewer node visits: its SAH cost (one unit per
    wide node, its four boxes at once) is below the binary tree's, the leaf term alone equal."""
    mesh = dense_mesh(3000, seed=4)
    lo, hi = triangle_bounds(mesh.vertices, mesh.faces)
    binary = build_bvh(lo, hi)
    wide = collapse(binary, 4)
    assert wide.sah_cost() < binary.sah_cost()
    assert wide.sah_cost(traversal_cost=0) == pytest.approx(binary.sah_cost(traversal_cost=0), rel=1e-9)
    area_lo, area_hi = binary.nodes["bmin"][0], binary.nodes["bmax"][0]
    assert half_area(area_lo.astype(np.float64), area_hi.astype(np.float64)) > 0


def three_ways(mesh, o, d, t_max, device, **kw):
    """(t, prim, occluded) from the 8- and 4-wide trees, the binary tree and no BVH (last)."""
    out = []
    for width, use_bvh in ((8, True), (4, True), (2, True), (4, False)):
        tracer = Tracer(mesh, bvh_width=width, use_bvh=use_bvh, device=device, **kw)
        t, prim, _ = tracer.intersect(o, d)
        out.append((t, prim, tracer.occluded(o, d, t_max)))
    return out


def assert_same_answers(answers, label):
    *trees, (t0, p0, b0) = answers
    assert np.isfinite(t0).any(), label
    for (t, p, b), name in zip(trees, ("8-wide", "4-wide", "binary")):
        np.testing.assert_array_equal(p, p0, err_msg=f"{label}: {name} primitive")
        np.testing.assert_array_equal(t, t0, err_msg=f"{label}: {name} t")  # the same float32 test: bit-equal
        np.testing.assert_array_equal(b, b0, err_msg=f"{label}: {name} occluded")


def test_wide_binary_and_brute_force_agree_on_random_rays(device):
    rng = np.random.default_rng(7)
    mesh = dense_mesh(2000, seed=7)
    v = np.asarray(mesh.vertices)
    o, d = rays_at_triangles(rng, v[np.asarray(mesh.faces)].reshape(-1, 3), 1500)
    o = np.concatenate([o, rng.uniform(v.min(0), v.max(0), (500, 3))])  # and rays starting inside the mesh
    d = np.concatenate([d, rng.normal(size=(500, 3))])
    assert_same_answers(three_ways(mesh, o, d, 15.0, device), "random")


def test_wide_binary_and_brute_force_agree_on_axis_aligned_and_grazing_rays(device):
    """A grid of unit squares in the plane z = 0 (boxes of zero thickness) and a wall behind it:
    axis-aligned rays whose origins lie exactly on box planes (the slab test's 0 * inf case), and
    grazing rays in the plane or nearly so."""
    k = 12
    xs = np.arange(k + 1, dtype=np.float64)
    gx, gy = np.meshgrid(xs, xs, indexing="ij")
    vertices = np.c_[gx.ravel(), gy.ravel(), np.zeros(gx.size)]
    idx = np.arange((k + 1) ** 2).reshape(k + 1, k + 1)
    a, b, c, e = idx[:-1, :-1].ravel(), idx[1:, :-1].ravel(), idx[1:, 1:].ravel(), idx[:-1, 1:].ravel()
    faces = np.concatenate([np.c_[a, b, c], np.c_[a, c, e]])
    # a wall across the far end (x = k + 1), so that rays in the plane end somewhere
    m = len(vertices)
    vertices = np.concatenate([vertices, [[k + 1, -1, -1], [k + 1, k + 1, -1], [k + 1, k + 1, 1], [k + 1, -1, 1]]])
    faces = np.concatenate([faces, [[m, m + 1, m + 2], [m, m + 2, m + 3]]])
    rng = np.random.default_rng(11)
    n = 400
    pts = np.c_[rng.integers(0, k + 1, (n, 2)) + rng.choice([0.0, 0.5], (n, 2)), np.zeros(n)]
    down = (pts + [0, 0, 3], np.tile([0.0, 0, -1], (n, 1)))  # on vertices, edges and face centres
    sideways = (
        np.c_[np.full(n, -2.0), pts[:, 1], rng.choice([0.0, 1e-7, -1e-7], n)],
        np.tile([1.0, 0, 0], (n, 1)),
    )  # in the plane, or a hair above or below it
    grazing = (
        np.c_[np.full(n, -2.0), pts[:, 1], np.full(n, 1e-3)],
        np.c_[np.ones(n), rng.uniform(-0.2, 0.2, n), np.full(n, -1e-3) / rng.uniform(1, 14, n)],
    )
    for label, (o, d) in (("axis-aligned", down), ("in-plane", sideways), ("grazing", grazing)):
        assert_same_answers(three_ways((vertices, faces), o, d, 30.0, device), label)


@pytest.mark.parametrize("stack_size", [None, 2])
def test_wide_tree_on_degenerate_meshes_matches_brute_force_even_when_its_stack_overflows(device, stack_size):
    """With a binary stack of 2 the wide stacks (scaled from it) hold 4 or 8 lanes: they overflow
    on purpose and the kernels' fallback must still give the brute-force answers."""
    knobs = DEFAULT_KNOBS if stack_size is None else TraceKnobs(stack_size=stack_size)
    rng = np.random.default_rng(23)
    for name, vertices in degenerate_meshes(rng):
        mesh = (vertices, np.arange(len(vertices)).reshape(-1, 3))
        o, d = rays_at_triangles(rng, vertices, 300)
        assert_same_answers(three_ways(mesh, o, d, 40.0, device, knobs=knobs), name)


def test_wide_tree_counts_fewer_node_visits_for_the_same_primitive_tests(device):
    """The BVH on/off harness stays honest: node visits and primitive tests are counted per ray, and
    the wide tree visits fewer nodes for about the same primitive tests on camera-like rays (both
    layouts over the same binary tree: leaves of at most 4)."""
    same_leaves = TraceKnobs(max_leaf_size=4)
    mesh = dense_mesh(5000, seed=2)
    v = np.asarray(mesh.vertices)
    centre = (v.min(0) + v.max(0)) / 2
    rng = np.random.default_rng(3)
    o = np.tile(centre + [0, 0, 3 * np.ptp(v, 0).max()], (2000, 1))
    d = centre + rng.uniform(-0.4, 0.4, (2000, 3)) * np.ptp(v, 0) - o
    visits = {}
    for width in (4, 2):
        for prims in (False, True):
            tracer = Tracer(mesh, bvh_width=width, count_prim_tests=prims, device=device, knobs=same_leaves)
            tracer.intersect(o, d)
            visits[width, prims] = tracer.last_visits.astype(np.int64)
    flat = Tracer(mesh, use_bvh=False, device=device)
    flat.intersect(o, d)
    assert (flat.last_visits == len(mesh.faces)).all()  # BVH off: every primitive, every ray
    assert visits[4, False].mean() < 0.75 * visits[2, False].mean()
    assert visits[4, True].mean() == pytest.approx(visits[2, True].mean(), rel=0.05)
    assert visits[4, True].mean() < 0.01 * len(mesh.faces)
    assert (visits[4, False] >= 1).all()  # the root is always visited
