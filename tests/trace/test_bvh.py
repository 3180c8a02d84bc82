"""Host BVH builders: layout and bounds invariants, edge cases, SAH quality, and a closest-hit
traversal in numpy against brute force."""

import numpy as np
import pytest

import clrender.trace.bvh as bvh_module
from clrender.errors import UsageError
from clrender.trace.bvh import BUILDERS, MAX_TREE_LEVELS, NODE_DTYPE, build_bvh


def soup(rng, n, size=0.05):
    """n random small triangles in the unit cube: (n, 3, 3) float32."""
    c = rng.random((n, 1, 3))
    return (c + (rng.random((n, 3, 3)) - 0.5) * size).astype(np.float32)


def check_tree(bvh, lo, hi, max_leaf=None):
    """Every invariant the kernels rely on."""
    nodes, order = bvh.nodes, bvh.prim_order
    n = len(lo)
    assert nodes.dtype == NODE_DTYPE and NODE_DTYPE.itemsize == 32
    assert order.dtype == np.int32 and np.array_equal(np.sort(order), np.arange(n))
    count, offset = nodes["count"], nodes["offset"]
    leaf = count > 0
    interior = np.flatnonzero(~leaf)
    # layout: near child at i + 1, far child after it
    assert (interior + 1 < len(nodes)).all()
    assert ((offset[interior] > interior + 1) & (offset[interior] < len(nodes))).all()
    # preorder: an explicit-stack walk from the root visits 0, 1, 2, ... and every node once
    visited, stack = [], [0]
    while stack:
        i = stack.pop()
        visited.append(i)
        if count[i] == 0:
            stack += [int(offset[i]), i + 1]
    assert visited == list(range(len(nodes)))
    # leaves cover the slots exactly once
    slots = np.concatenate([np.arange(o, o + c) for o, c in zip(offset[leaf], count[leaf])])
    assert np.array_equal(np.sort(slots), np.arange(n))
    # bounds contain children and primitives
    bmin, bmax = nodes["bmin"], nodes["bmax"]
    for child in (interior + 1, offset[interior]):
        assert (bmin[interior] <= bmin[child]).all() and (bmax[interior] >= bmax[child]).all()
    leaf_of_slot = np.repeat(np.flatnonzero(leaf), count[leaf])
    prims = order[np.concatenate([np.arange(o, o + c) for o, c in zip(offset[leaf], count[leaf])])]
    assert (bmin[leaf_of_slot] <= lo[prims]).all() and (bmax[leaf_of_slot] >= hi[prims]).all()
    assert bvh.depth <= MAX_TREE_LEVELS
    if max_leaf is not None:
        assert bvh.max_leaf_size <= max_leaf
    assert bvh.node_count == len(nodes) and bvh.leaf_count == int(leaf.sum())


@pytest.mark.parametrize("builder", BUILDERS)
@pytest.mark.parametrize("n", [1, 2, 3, 5, 17, 64, 1000])
def test_invariants_random_soup(builder, n):
    tri = soup(np.random.default_rng(n), n)
    lo, hi = tri.min(1), tri.max(1)
    bvh = build_bvh(lo, hi, builder=builder)
    check_tree(bvh, lo, hi, max_leaf=4 if builder == "median" else 16)
    assert bvh.builder == builder and bvh.build_seconds >= 0


@pytest.mark.parametrize("builder", BUILDERS)
def test_no_primitives(builder):
    bvh = build_bvh(np.zeros((0, 3), np.float32), np.zeros((0, 3), np.float32), builder=builder)
    assert len(bvh.nodes) == 1 and bvh.nodes["count"][0] == 0 and bvh.nodes["offset"][0] == 0
    assert len(bvh.prim_order) == 0 and bvh.depth == 1


def test_single_primitive_is_one_leaf():
    lo, hi = np.array([[0, 1, 2]], np.float32), np.array([[1, 2, 3]], np.float32)
    bvh = build_bvh(lo, hi)
    assert len(bvh.nodes) == 1 and bvh.nodes["count"][0] == 1 and bvh.nodes["offset"][0] == 0
    assert np.array_equal(bvh.nodes["bmin"][0], lo[0]) and np.array_equal(bvh.nodes["bmax"][0], hi[0])


@pytest.mark.parametrize("builder", BUILDERS)
@pytest.mark.parametrize("max_leaf", [1, 2, 4])
def test_identical_boxes(builder, max_leaf):
    """All centroids coincide: no SAH bin split exists, the builder halves instead."""
    lo = np.tile(np.float32([[0.5, 0.5, 0.5]]), (100, 1))
    bvh = build_bvh(lo, lo + 0.1, builder=builder, max_leaf_size=max_leaf)
    check_tree(bvh, lo, lo + 0.1, max_leaf=4 * max_leaf)


@pytest.mark.parametrize("builder", BUILDERS)
def test_flat_and_point_boxes(builder, rng):
    """Boxes of zero thickness (a planar mesh) and zero size (points) in every axis."""
    for flat_axes in ([2], [0, 1, 2]):
        lo = rng.random((500, 3)).astype(np.float32)
        hi = lo + rng.random((500, 3)).astype(np.float32) * 0.01
        lo[:, flat_axes] = 0.25
        hi[:, flat_axes] = 0.25
        check_tree(build_bvh(lo, hi, builder=builder), lo, hi)


def test_sampled_and_halving_paths_keep_invariants(rng):
    """Big nodes bin a sample, small ones can be halved along their widest axis: force both at small sizes."""
    tri = soup(rng, 5000, size=0.2)
    lo, hi = tri.min(1), tri.max(1)
    for samples, halving in ((16, 8), (64, 100), (4096, 4)):
        bvh = build_bvh(lo, hi, sah_samples=samples, halving_below=halving)
        check_tree(bvh, lo, hi, max_leaf=16)


def test_depth_is_capped():
    """Boxes at 16^i make binned SAH peel one primitive per level; with the cap lowered to 12 the
    builder switches to halving in time."""
    x = np.float32(16.0) ** np.arange(31, dtype=np.float32)
    lo = np.concatenate([np.stack([x, 0 * x, 0 * x], axis=1), np.random.default_rng(0).random((200, 3))])
    lo = lo.astype(np.float32)
    assert build_bvh(lo, lo + 1, max_leaf_size=1).depth > 16
    for builder in BUILDERS:
        bvh = build_bvh(lo, lo + 1, builder=builder, max_leaf_size=1, max_levels=12)
        assert bvh.depth <= 12
        check_tree(bvh, lo, lo + 1)


def test_median_is_the_seeds_rule(rng):
    """Sorted by centroid x, each node split into halves (left count // 2), leaves of <= 4."""
    tri = soup(rng, 203)
    lo, hi = tri.min(1), tri.max(1)
    bvh = build_bvh(lo, hi, builder="median")
    assert np.array_equal(bvh.prim_order, np.argsort(lo[:, 0] + hi[:, 0], kind="stable"))

    def leaf_sizes(n):  # preorder leaf sizes of the halving recursion
        return [n] if n <= 4 else leaf_sizes(n // 2) + leaf_sizes(n - n // 2)

    nodes = bvh.nodes
    assert list(nodes["count"][nodes["count"] > 0]) == leaf_sizes(203)


def test_sah_cost_of_a_hand_built_tree():
    lo = np.float32([[0, 0, 0], [2, 0, 0]])
    bvh = build_bvh(lo, lo + 1, max_leaf_size=1)
    # root: 3 x 1 x 1 box (half area 7); two unit-cube leaves (half area 3) of one primitive
    assert bvh.sah_cost() == pytest.approx(1 + (3 + 3) / 7)
    assert bvh.sah_cost(traversal_cost=2, intersect_cost=0.5) == pytest.approx(2 + 0.5 * 6 / 7)


def test_sah_beats_median_on_a_soup(rng):
    tri = soup(rng, 20000, size=0.02)
    lo, hi = tri.min(1), tri.max(1)
    sah, median = build_bvh(lo, hi, "sah"), build_bvh(lo, hi, "median")
    assert sah.sah_cost() <= median.sah_cost()


def test_deterministic(rng):
    tri = soup(rng, 3000)
    lo, hi = tri.min(1), tri.max(1)
    for builder in BUILDERS:
        a, b = build_bvh(lo, hi, builder), build_bvh(lo, hi, builder)
        assert a.nodes.tobytes() == b.nodes.tobytes() and np.array_equal(a.prim_order, b.prim_order)


@pytest.mark.parametrize(
    "bad",
    [
        dict(lo=np.zeros((3, 2)), hi=np.zeros((3, 2))),
        dict(lo=np.zeros((3, 3)), hi=np.zeros((4, 3))),
        dict(lo=np.full((3, 3), np.nan), hi=np.zeros((3, 3))),
        dict(lo=np.ones((3, 3)), hi=np.zeros((3, 3))),
        dict(builder="octree"),
        dict(max_leaf_size=0),
        dict(bins=1),
        dict(bins=bvh_module.MAX_BINS + 1),
        dict(halving_below=-1),
    ],
)
def test_bad_input(bad):
    args = dict(lo=np.zeros((3, 3)), hi=np.ones((3, 3)), builder="sah")
    args.update(bad)
    with pytest.raises(UsageError):
        build_bvh(**args)


# ------------------------------------------------------------ traversal reference
def ray_triangles(o, d, tri):
    """Möller-Trumbore for one ray against triangles (m, 3, 3): t per triangle, inf on a miss."""
    e1, e2 = tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]
    p = np.cross(d, e2)
    det = np.einsum("ij,ij->i", e1, p)
    ok = np.abs(det) > 1e-12
    inv = np.where(ok, 1 / np.where(ok, det, 1), 0)
    s = o - tri[:, 0]
    u = np.einsum("ij,ij->i", s, p) * inv
    q = np.cross(s, e1)
    v = (q @ d) * inv
    t = np.einsum("ij,ij->i", e2, q) * inv
    hit = ok & (u >= 0) & (v >= 0) & (u + v <= 1) & (t > 1e-9)
    return np.where(hit, t, np.inf)


def slab(o, inv_d, bmin, bmax, t_max):
    t0, t1 = (bmin - o) * inv_d, (bmax - o) * inv_d
    near = np.minimum(t0, t1).max()
    far = np.maximum(t0, t1).min()
    return near <= far and far >= 0 and near <= t_max


def closest_hit(bvh, tri, o, d):
    """Near-first traversal with a stack, as the kernel does: (t, primitive id)."""
    nodes = bvh.nodes
    inv_d = 1 / np.where(d == 0, 1e-30, d)
    best_t, best_id, stack = np.inf, -1, [0]
    while stack:
        i = stack.pop()
        if not slab(o, inv_d, nodes["bmin"][i], nodes["bmax"][i], best_t):
            continue
        if nodes["count"][i] > 0:
            ids = bvh.prim_order[nodes["offset"][i] : nodes["offset"][i] + nodes["count"][i]]
            t = ray_triangles(o, d, tri[ids])
            j = int(np.argmin(t))
            if t[j] < best_t:
                best_t, best_id = t[j], int(ids[j])
        else:
            stack += [int(nodes["offset"][i]), i + 1]
    return best_t, best_id


@pytest.mark.parametrize("builder", BUILDERS)
def test_closest_hit_matches_brute_force(builder, rng):
    tri = soup(rng, 400, size=0.3).astype(np.float64)
    bvh = build_bvh(tri.min(1), tri.max(1), builder=builder, max_leaf_size=2)
    hits = 0
    for _ in range(200):
        o = rng.random(3) * 3 - 1
        d = rng.random(3) - o  # aim into the cube
        d /= np.linalg.norm(d)
        t_all = ray_triangles(o, d, tri)
        t, pid = closest_hit(bvh, tri, o, d)
        if np.isfinite(t_all.min()):
            hits += 1
            assert t == t_all.min() and pid == int(np.argmin(t_all))
        else:
            assert pid == -1
    assert hits > 50


def test_float64_bounds_round_outward(rng):
    """Bounds given in float64 must not shrink when stored as float32."""
    lo = rng.random((300, 3)) * 10 + 1e-9
    hi = lo + rng.random((300, 3)) * 1e-3
    bvh = build_bvh(lo, hi)
    leaf = bvh.nodes["count"] > 0
    slot_leaf = np.repeat(np.flatnonzero(leaf), bvh.nodes["count"][leaf])
    prims = bvh.prim_order[np.concatenate([np.arange(o, o + c) for o, c in zip(bvh.nodes["offset"][leaf], bvh.nodes["count"][leaf])])]
    assert (bvh.nodes["bmin"][slot_leaf].astype(np.float64) <= lo[prims]).all()
    assert (bvh.nodes["bmax"][slot_leaf].astype(np.float64) >= hi[prims]).all()


@pytest.mark.parametrize("halving_below", [0, 1000])
def test_top_level_launches_give_the_same_tree_as_one_subtree(rng, halving_below):
    """The SAH build splits its top levels one node per work-item and launch, then builds each
    remaining subtree in one work-item: the tree must not depend on where that switch happens
    (clustered input: subtrees end at different depths)."""
    tri = np.concatenate([soup(rng, 3000, size=0.1), soup(rng, 1000, size=0.001) * 0.01])
    lo, hi = tri.min(1), tri.max(1)
    single = build_bvh(lo, hi, halving_below=halving_below, top_min=10**9)  # the root's whole tree in one work-item
    # nodes of more than 8 primitives split by split_level
    many = build_bvh(lo, hi, halving_below=halving_below, top_min=8, top_tasks=10**9)
    check_tree(many, lo, hi)
    assert many.nodes.tobytes() == single.nodes.tobytes()
    assert np.array_equal(many.prim_order, single.prim_order)


def test_sah_tree_does_not_depend_on_the_scene_scale(rng):
    """Scaling a scene by a power of two scales every float exactly: the SAH choices, and so the
    tree's shape and order, must stay the same even where areas would overflow (2**100 squared)
    or underflow (2**-90 squared) float32."""
    tri = soup(rng, 3000)
    lo, hi = tri.min(1), tri.max(1)
    ref = build_bvh(lo, hi)
    for k in (-90, 100):
        scale = np.float32(2.0**k)
        bvh = build_bvh(lo * scale, hi * scale)
        check_tree(bvh, lo * scale, hi * scale)
        assert np.array_equal(bvh.prim_order, ref.prim_order)
        assert np.array_equal(bvh.nodes[["offset", "count"]], ref.nodes[["offset", "count"]])
        assert np.array_equal(bvh.nodes["bmin"], ref.nodes["bmin"] * scale)


def room_with_clutter(rng, n_small=300):
    """A closed room's six walls (two triangles each, the size of the scene) around n_small small triangles."""
    corners = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1]], np.float32)
    faces = [(0, 1, 2, 3), (4, 5, 6, 7), (0, 1, 5, 4), (3, 2, 6, 7), (0, 3, 7, 4), (1, 2, 6, 5)]
    walls = np.array([[corners[a], corners[b], corners[c]] for f in faces for a, b, c in ((f[0], f[1], f[2]), (f[0], f[2], f[3]))])
    return np.concatenate([walls, soup(rng, n_small, size=0.02) * 0.8 + 0.1])


def leaves_of(bvh):
    """Each leaf's primitive ids."""
    nodes, order = bvh.nodes, bvh.prim_order
    return [order[o : o + c] for o, c in zip(nodes["offset"], nodes["count"]) if c > 0]


def test_a_large_primitive_shares_its_leaf_with_at_most_one_other(rng):
    """A wall (its box a third of the room's surface area: large, LARGE_SHARE) would make every ray that meets its leaf
    test the leaf's small triangles too: it is kept in a leaf of at most two (its quad's other half)."""
    tri = room_with_clutter(rng)
    lo, hi = tri.min(1), tri.max(1)
    bvh = build_bvh(lo, hi, max_leaf_size=6)
    check_tree(bvh, lo, hi)
    large = np.arange(len(tri)) < 12  # the walls
    leaves = leaves_of(bvh)
    assert all(len(leaf) <= 2 for leaf in leaves if large[leaf].any())
    assert max(len(leaf) for leaf in leaves if not large[leaf].any()) > 2  # the clutter keeps its bigger leaves


def test_without_large_primitives_the_tree_is_the_one_the_rule_leaves_alone(rng, monkeypatch):
    """Small triangles only: the tree is bit for bit the one built with the large-primitive rule switched off."""
    tri = soup(rng, 3000)
    lo, hi = tri.min(1), tri.max(1)
    with_rule = build_bvh(lo, hi, max_leaf_size=6)
    monkeypatch.setattr(bvh_module, "LARGE_SHARE", np.inf)
    without = build_bvh(lo, hi, max_leaf_size=6)
    assert np.array_equal(with_rule.prim_order, without.prim_order) and np.array_equal(with_rule.nodes, without.nodes)


def test_builds_from_several_threads_give_the_same_tree(rng):
    """The device build shares its kernel objects: concurrent callers must not mix their arguments."""
    import threading

    tri = soup(rng, 5000)
    lo, hi = tri.min(1), tri.max(1)
    ref = build_bvh(lo, hi)
    trees = [None] * 4

    def build(i):
        trees[i] = build_bvh(lo, hi)

    threads = [threading.Thread(target=build, args=(i,)) for i in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert all(t.nodes.tobytes() == ref.nodes.tobytes() and np.array_equal(t.prim_order, ref.prim_order) for t in trees)


def test_sah_refuses_more_primitives_than_its_int32_indices_reach(monkeypatch):
    monkeypatch.setattr(bvh_module, "MAX_SAH_PRIMS", 10)
    lo = np.zeros((11, 3), np.float32)
    with pytest.raises(UsageError, match="at most 10"):
        build_bvh(lo, lo + 1)
    assert build_bvh(lo, lo + 1, builder="median").leaf_count > 1


def test_root_leaf_above_the_subtree_size():
    """A root that the top-level launch makes a leaf (more primitives than a subtree task, at most
    max_leaf_size) is the whole tree."""
    lo = np.random.default_rng(3).random((20, 3)).astype(np.float32)
    bvh = build_bvh(lo, lo + 0.1, max_leaf_size=100, top_min=8)
    check_tree(bvh, lo, lo + 0.1)
    assert len(bvh.nodes) == 1 and bvh.nodes["count"][0] == 20


# ------------------------------------------------------------ SAH choices against brute force
def box_half_area(lo, hi):
    e = np.maximum(hi.max(0).astype(np.float64) - lo.min(0).astype(np.float64), 0)
    return e[0] * e[1] + e[1] * e[2] + e[2] * e[0]


def binned_cuts(lo, hi, bins):
    """Every cut between bins along every axis, tried one by one: a list of (cost, left mask) with
    cost = area(L) N_L + area(R) N_R in float64 from the primitives' own bounds.  A primitive's bin
    is computed as the kernel must (float32: twice the centroid, floor((c - cmin) * bins / extent),
    the last bin taking the top), since that decides which primitives a cut can separate."""
    n_bins = bins if len(lo) > 2 * bins else max(bins // 2, 2)
    c = lo + hi
    cmin, extent = c.min(0), c.max(0) - c.min(0)
    cuts = []
    for axis in range(3):
        if not extent[axis] > 0:
            continue
        t = (c[:, axis] - cmin[axis]) * (np.float32(n_bins) / extent[axis])
        b = np.where(t < n_bins - 1, np.floor(t), n_bins - 1)
        for cut in range(n_bins - 1):
            left = b <= cut
            if left.all() or not left.any():
                continue
            cost = box_half_area(lo[left], hi[left]) * left.sum() + box_half_area(lo[~left], hi[~left]) * (~left).sum()
            cuts.append((cost, left))
    return cuts


@pytest.mark.parametrize("max_leaf", [1, 4])
def test_every_sah_split_is_the_cheapest_binned_cut(rng, max_leaf):
    """Each node of the device-built tree (all primitives binned: no sampling) is split by one of
    the cheapest cuts a brute-force search finds (equal partitions found along two axes cost the
    same up to float32 rounding, so costs are compared, not which one), or is a leaf exactly when
    the rule says so."""
    tri = soup(rng, 700, size=0.08)
    lo, hi = tri.min(1), tri.max(1)
    bins = 8
    bvh = build_bvh(lo, hi, max_leaf_size=max_leaf, bins=bins, sah_samples=10**6)
    check_tree(bvh, lo, hi)
    nodes, order = bvh.nodes, bvh.prim_order

    def slots(i):  # (first slot, count) of node i's subtree
        if nodes["count"][i] > 0:
            return int(nodes["offset"][i]), int(nodes["count"][i])
        (a, na), (_, nb) = slots(i + 1), slots(int(nodes["offset"][i]))
        return a, na + nb

    checked = 0
    for i in range(len(nodes)):
        first, count = slots(i)
        ids = order[first : first + count]
        cuts = binned_cuts(lo[ids], hi[ids], bins)
        best = min((cost for cost, _ in cuts), default=np.inf)
        node_cost = 1 + best / box_half_area(lo[ids], hi[ids])
        if nodes["count"][i] > 0:
            assert count <= max_leaf or (count <= 4 * max_leaf and node_cost >= count)
            continue
        assert count > max_leaf and not (count <= 4 * max_leaf and node_cost >= count)
        near_first, near_count = slots(i + 1)
        near = set(order[first : first + near_count])
        assert near_first == first
        cost = [cost for cost, left in cuts if set(ids[left]) == near]
        assert cost and cost[0] <= best * (1 + 1e-5)
        checked += 1
    assert checked > 100


@pytest.mark.parametrize("n", [16, 31])
def test_sah_trees_that_must_be_capped_stop_at_every_cap(n):
    """Boxes at 16^i: binned SAH peels one box per level, so uncapped the tree is n levels deep.  Under
    any cap from the least that can hold n leaves (ceil(log2 n) + 1 levels) up to n - 1 the builder must
    switch to halving in time: never deeper than the cap, and no shallower than one level above it (the
    cap binds; the builder keeps at most one level spare)."""
    x = np.float32(16.0) ** np.arange(n, dtype=np.float32)
    lo = np.stack([x, 0 * x, 0 * x], axis=1)
    assert build_bvh(lo, lo + 1, max_leaf_size=1).depth == n
    least = int(np.ceil(np.log2(n))) + 1
    for cap in range(least, n):
        # whole subtrees per work-item (the default here), and every level split by the host's launches
        for top_tasks, top_min in ((bvh_module.TOP_TASKS, bvh_module.TOP_MIN), (n, 1)):
            bvh = build_bvh(lo, lo + 1, max_leaf_size=1, max_levels=cap, top_tasks=top_tasks, top_min=top_min)
            assert cap - 1 <= bvh.depth <= cap, (cap, top_tasks, bvh.depth)
            check_tree(bvh, lo, lo + 1)
