"""Bounding volume hierarchy, built on the host with numpy and read as-is by the kernels.

Layout (pbrt's "linear BVH"): a flat depth-first array of 32-byte nodes, two
float4 each in the kernel::

    bmin.xyz, offset | bmax.xyz, count

* leaf: ``count > 0``; its primitives are ``prim_order[offset:offset + count]``
* interior: ``count == 0``; the near (first) child is node ``i + 1``, the far
  (second) child is node ``offset`` (always ``> i``)
* node 0 is the root; a node's bounds contain its children and its primitives.
* no primitives: a single node with zero bounds, count 0 and offset 0 (the
  kernels never traverse it: they test ``n_prims == 0`` first).

Builders (both vectorised: the tree grows one level at a time, every node of a
level handled at once with segment operations, then the breadth-first tree is
renumbered depth-first):

* ``sah`` -- binned surface area heuristic: ``bins`` bins over the centroid
  bounds of each node, along all three axes, best cut by SAH cost.  Nodes larger
  than ``sah_samples`` primitives evaluate their bins on an evenly strided sample
  of that many primitives (the cut then partitions all of them).  A node becomes
  a leaf when it holds at most ``max_leaf_size`` primitives, or when no cut is
  cheaper than the leaf and it holds at most ``4 * max_leaf_size``.  Nodes of
  at most ``2 * bins`` primitives use ``bins // 2`` bins.  A node of
  at most ``halving_below`` primitives, one whose centroids all fall in one bin
  (e.g. they coincide), or one too deep for MAX_TREE_LEVELS is finished by halving:
  its primitives are sorted once by Morton code and every split below cuts the
  range in halves (count // 2 to the first child).
* ``median`` -- the seed's rule: primitives sorted by centroid x, every node
  split into halves (the first child gets ``count // 2``), leaves of at most
  ``max_leaf_size``.

Every tree is at most ``MAX_TREE_LEVELS`` levels deep (the kernels' traversal stack
is 64 entries): SAH nodes switch to halving early enough.  SAH builds of more
than ``PARALLEL_ABOVE`` primitives grow their subtrees in two threads
(two groups of whole subtrees below the third level; numpy releases the GIL in
its array loops); the tree is the same either way.
"""

from __future__ import annotations

import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, replace
from functools import partial

import numpy as np

from ..errors import UsageError
from ..layout import BVH_NODE_ROWS

NODE_DTYPE = np.dtype([("bmin", "<f4", 3), ("offset", "<i4"), ("bmax", "<f4", 3), ("count", "<i4")])
assert NODE_DTYPE.itemsize == 16 * BVH_NODE_ROWS  # the kernels read a node as BVH_NODE_ROWS float4s
BUILDERS = ("sah", "median")
MAX_TREE_LEVELS = 48  # levels, root included
# The kernels' traversal stack (-DSTACK_SIZE): near-first closest-hit traversal keeps at most
# depth - 1 far nodes, any-hit traversal at most depth nodes, so a tree of MAX_TREE_LEVELS levels always
# fits (the kernels also fall back to testing every primitive should a stack ever fill up).
STACK_SIZE = 64
assert MAX_TREE_LEVELS <= STACK_SIZE
SAH_SAMPLES = 256  # nodes larger than this bin a strided sample of this many primitives
HALVING_BELOW = 16  # SAH nodes of at most this many primitives finish by Morton-order halving
PARALLEL_ABOVE = 100_000  # SAH builds of more primitives grow the root's two subtrees in two threads
_OLD = False
TRAVERSAL_COST = 1.0  # SAH cost of visiting an interior node, relative to one primitive test
INTERSECT_COST = 1.0


@dataclass
class BVH:
    nodes: np.ndarray  # NODE_DTYPE, depth-first, node 0 the root
    prim_order: np.ndarray  # int32 (n_prims,): leaf slots -> primitive ids, a permutation
    build_seconds: float  # wall time of build_bvh
    builder: str  # "sah" or "median"

    @property
    def node_count(self) -> int:
        return len(self.nodes)

    @property
    def is_leaf(self) -> np.ndarray:
        return self.nodes["count"] > 0

    @property
    def leaf_count(self) -> int:
        return int(self.is_leaf.sum())

    @property
    def max_leaf_size(self) -> int:
        return int(self.nodes["count"].max(initial=0))

    @property
    def depth(self) -> int:
        """Levels on the longest root-to-leaf path (a lone root leaf: 1)."""
        return int(node_depths(self.nodes).max()) + 1

    def sah_cost(self, traversal_cost: float = TRAVERSAL_COST, intersect_cost: float = INTERSECT_COST) -> float:
        """Expected cost of a random ray hitting the root: sum over nodes of area(node) / area(root)
        times traversal_cost (interior) or intersect_cost * count (leaf).  A root of zero area
        weighs every node 1."""
        lo, hi = self.nodes["bmin"].astype(np.float64), self.nodes["bmax"].astype(np.float64)
        area = half_area(lo, hi)
        rel = area / area[0] if area[0] > 0 else np.ones_like(area)
        count = self.nodes["count"]
        per_node = np.where(count > 0, intersect_cost * count, traversal_cost)
        return float((rel * per_node).sum())

    def stats(self) -> dict:
        return dict(
            builder=self.builder,
            nodes=self.node_count,
            leaves=self.leaf_count,
            depth=self.depth,
            max_leaf_size=self.max_leaf_size,
            sah_cost=self.sah_cost(),
            build_s=self.build_seconds,
        )


def half_area(lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """Half the surface area of boxes (..., 3); empty boxes (hi < lo) count 0."""
    e = np.maximum(hi - lo, 0)
    return e[..., 0] * e[..., 1] + e[..., 1] * e[..., 2] + e[..., 2] * e[..., 0]


def node_depths(nodes: np.ndarray) -> np.ndarray:
    """Depth of every node (root 0) of a depth-first node array, level by level."""
    depth = np.zeros(len(nodes), np.int64)
    interior = np.flatnonzero(nodes["count"] == 0) if len(nodes) > 1 else np.zeros(0, np.int64)
    children = np.full((len(nodes), 2), -1, np.int64)
    children[interior, 0], children[interior, 1] = interior + 1, nodes["offset"][interior]
    frontier, level = np.array([0]), 0
    while len(frontier):
        depth[frontier] = level
        c = children[frontier].ravel()
        frontier, level = c[c >= 0], level + 1
    return depth


def build_bvh(
    lo: np.ndarray,
    hi: np.ndarray,
    builder: str = "sah",
    max_leaf_size: int = 4,
    bins: int = 16,
    *,
    sah_samples: int = SAH_SAMPLES,
    halving_below: int = HALVING_BELOW,
) -> BVH:
    """Build a BVH over N primitives given their bounds lo, hi (each (N, 3))."""
    start = time.perf_counter()
    if builder not in BUILDERS:
        raise UsageError(f"unknown BVH builder {builder!r}; allowed: {', '.join(BUILDERS)}")
    if int(max_leaf_size) < 1:
        raise UsageError(f"max_leaf_size {max_leaf_size}; allowed: 1 or more")
    if int(bins) < 2:
        raise UsageError(f"bins {bins}; allowed: 2 or more")
    if int(sah_samples) < 2:
        raise UsageError(f"sah_samples {sah_samples}; allowed: 2 or more")
    lo, hi = _as_float32(lo, -np.inf), _as_float32(hi, np.inf)
    if lo.ndim != 2 or lo.shape[1:] != (3,) or lo.shape != hi.shape:
        raise UsageError(f"primitive bounds of shapes {lo.shape} and {hi.shape}; allowed: two (N, 3) arrays")
    n = len(lo)
    if n >= 2**31:
        raise UsageError(f"{n} primitives; allowed: fewer than 2**31")
    if n == 0:
        nodes = np.zeros(1, NODE_DTYPE)
        return BVH(nodes, np.zeros(0, np.int32), time.perf_counter() - start, builder)
    if not (np.isfinite(lo).all() and np.isfinite(hi).all()):
        raise UsageError("primitive bounds with NaN or infinite values; allowed: finite numbers")
    if (hi < lo).any():
        raise UsageError("primitive bounds with hi < lo; allowed: boxes with lo <= hi")
    if builder == "median":
        levels, order = _median_levels(lo, hi, int(max_leaf_size))
        nodes = _depth_first(levels)
    elif _OLD:
        levels, order = _sah_levels(lo, hi, int(max_leaf_size), int(bins), int(sah_samples), int(halving_below))
        nodes = _depth_first(levels)
    else:
        nodes, order = _sah_device(lo, hi, int(max_leaf_size), int(bins), int(sah_samples), int(halving_below))
    return BVH(nodes, order.astype(np.int32), time.perf_counter() - start, builder)


def _as_float32(a, toward):
    """float32 copy of bounds, rounded outward (toward -inf for lo, +inf for hi) so no box shrinks."""
    a = np.asarray(a)
    if a.dtype == np.float32 or a.dtype.kind not in "fiu":
        return np.asarray(a, np.float32)
    b = a.astype(np.float32)
    shrunk = (b > a) if toward < 0 else (b < a)
    if shrunk.any():
        b[shrunk] = np.nextafter(b[shrunk], np.float32(toward))
    return b


# ---------------------------------------------------------------- level records
@dataclass
class _Level:
    bmin: np.ndarray  # (k, 3) float32
    bmax: np.ndarray  # (k, 3) float32
    start: np.ndarray  # (k,) first slot in prim_order
    count: np.ndarray  # (k,) primitives below the node
    split: np.ndarray  # (k,) bool: interior node
    child: np.ndarray  # (number of split nodes,) index of the first child in the next level; the second is next to it


def _depth_first(levels: list[_Level]) -> np.ndarray:
    """Renumber a breadth-first tree in preorder: subtree sizes bottom-up, then indices top-down."""
    sizes = [None] * len(levels)
    for d in range(len(levels) - 1, -1, -1):
        lv = levels[d]
        size = np.ones(len(lv.count), np.int64)
        if lv.split.any():
            below = sizes[d + 1]
            size[lv.split] += below[lv.child] + below[lv.child + 1]
        sizes[d] = size
    nodes = np.zeros(int(sizes[0][0]), NODE_DTYPE)
    pre = np.zeros(1, np.int64)
    for d, lv in enumerate(levels):
        leaf = ~lv.split
        nodes["bmin"][pre] = lv.bmin
        nodes["bmax"][pre] = lv.bmax
        nodes["count"][pre[leaf]] = lv.count[leaf]
        nodes["offset"][pre[leaf]] = lv.start[leaf]
        if not lv.split.any():
            break
        near = pre[lv.split] + 1  # the first child follows its parent
        far = near + sizes[d + 1][lv.child]  # the second follows the first's subtree
        nodes["offset"][pre[lv.split]] = far
        nxt = np.empty(len(sizes[d + 1]), np.int64)
        nxt[lv.child], nxt[lv.child + 1] = near, far
        pre = nxt
    return nodes


def _segments(count: np.ndarray):
    """First index of each segment and the segment of each element, for segments of these sizes."""
    seg_start = np.zeros(len(count), np.int64)
    np.cumsum(count[:-1], out=seg_start[1:])
    return seg_start, np.repeat(np.arange(len(count)), count)


def _halves(start, count):
    """Children of splitting ranges in halves (the first gets count // 2), as interleaved pairs."""
    left = count // 2
    return np.stack([start, start + left], axis=1).ravel(), np.stack([left, count - left], axis=1).ravel()


def _range_bounds(box, start, count):
    """Bounds of the ranges [start, start + count) of box (6, n + 1): sorted, disjoint, non-empty."""
    ranges = np.stack([start, start + count], axis=1).ravel()  # keep every other reduction
    box = box[:, : ranges[-1] + 1]  # the last (discarded) reduction covers one column only
    bmin = np.minimum.reduceat(box[0:3], ranges, axis=1)[:, 0::2].T
    bmax = np.maximum.reduceat(box[3:6], ranges, axis=1)[:, 0::2].T
    return bmin, bmax


# ---------------------------------------------------------------- median (seed)
def _median_levels(lo, hi, max_leaf):
    """The seed's builder: one sort by centroid x, then every node splits its range in halves."""
    order = np.argsort(lo[:, 0] + hi[:, 0], kind="stable")
    box = np.zeros((6, len(lo) + 1), np.float32)
    box[0:3, :-1], box[3:6, :-1] = lo[order].T, hi[order].T
    levels = []
    start, count = np.zeros(1, np.int64), np.array([len(lo)], np.int64)
    while len(start):
        bmin, bmax = _range_bounds(box, start, count)
        split = count > max_leaf
        levels.append(_Level(bmin, bmax, start, count, split, 2 * np.arange(split.sum())))
        start, count = _halves(start[split], count[split])
    return levels, order


# ---------------------------------------------------------------- binned SAH
@dataclass
class _Frontier:
    """The nodes one level of the SAH build works on.

    Active nodes still split by SAH bins: `box` holds their primitives' bounds as (6, n) rows
    lo.xyz, hi.xyz, node after node, `ids` the primitives in the same order.  Halving nodes
    have their primitives at their final slots already and only split slot ranges in halves.
    """

    box: np.ndarray  # (6, n) float32 bounds of the active nodes' primitives
    ids: np.ndarray  # (n,) int32 primitive ids, in the same order
    start: np.ndarray  # (k,) first final slot of each active node
    count: np.ndarray  # (k,) primitives of each active node
    hstart: np.ndarray  # (h,) first slot of each halving node
    hcount: np.ndarray  # (h,) primitives of each halving node
    depth: int  # tree level of these nodes (the root is level 1)


@dataclass
class _Splits:
    """What one level decided for its k active nodes (one entry per node unless said)."""

    split: np.ndarray  # bool: an interior node
    enter: np.ndarray  # bool: leaves the active set and splits slot ranges in halves from here on
    binned: np.ndarray  # bool: splits by its best SAH bin
    axis: np.ndarray | None  # the bin split's axis
    cut: np.ndarray | None  # primitives with bin <= cut go left
    bmin: np.ndarray  # (k, 3) float32 node bounds
    bmax: np.ndarray
    seg_start: np.ndarray | None  # first column of each node in the frontier's `box`
    cen: np.ndarray | None  # (3, n) twice the primitives' centroids
    cmin: np.ndarray | None  # (k, 3) lowest centroid of each node that splits
    scale: np.ndarray | None  # (k, 3) bins per unit of centroid extent


class _SahBuild:
    """Binned SAH, one level at a time.

    Every level splits the active nodes by their best SAH bin.  A node that is small, too deep, or
    has no bin split leaves the active set ("enters" halving): its primitives are sorted once by
    Morton code (of the centroid, within the node's centroid bounds) and written at their final
    slots (`order`, and their bounds to `fixed`); its subtree then splits slot ranges in halves,
    which only needs the bounds of those ranges.  Leaves leave the active set the same way.
    """

    def __init__(self, n_total: int, max_leaf: int, bins: int, samples: int, small: int):
        self.max_leaf, self.bins, self.samples, self.small = max_leaf, bins, samples, small
        self.leaf_cap = 4 * max_leaf
        self.order = np.empty(n_total, np.int32)  # primitive id by final slot
        self.fixed = np.zeros((6, n_total + 1), np.float32)  # bounds by final slot, for the halving nodes

    def grow(self, frontier: _Frontier, max_levels: int) -> tuple[list[_Level], _Frontier]:
        """Run the level loop on a frontier; returns its levels and the frontier left."""
        box, ids, gstart, count = frontier.box, frontier.ids, frontier.start, frontier.count
        hstart, hcount, depth = frontier.hstart, frontier.hcount, frontier.depth
        max_leaf, fixed = self.max_leaf, self.fixed
        levels = []
        while (len(count) or len(hcount)) and len(levels) < max_levels:
            k = len(count)
            box, ids, sp = self._choose_splits(box, ids, count, depth)
            hsplit = hcount > max_leaf
            hmin, hmax = _range_bounds(fixed, hstart, hcount) if len(hcount) else (sp.bmin[:0], sp.bmin[:0])

            # next level: children of binned nodes (active), then halves of entering and halving nodes
            split, enter, binned = sp.split, sp.enter, sp.binned
            n_binned = int(binned.sum())
            e_start, e_count = _halves(gstart[enter], count[enter])
            h_start, h_count = _halves(hstart[hsplit], hcount[hsplit])
            both = np.concatenate([e_start, h_start])
            srt = np.argsort(both, kind="stable")  # two sorted runs: keep the halving nodes sorted by slot
            where = np.empty(len(both), np.int64)
            where[srt] = np.arange(len(both))
            child_active = np.zeros(k, np.int64)
            child_active[binned] = 2 * np.arange(n_binned)
            child_active[enter] = 2 * n_binned + where[0 : len(e_start) : 2]
            child_h = 2 * n_binned + where[len(e_start) :: 2]
            levels.append(
                _Level(
                    np.concatenate([sp.bmin, hmin]),
                    np.concatenate([sp.bmax, hmax]),
                    np.concatenate([gstart, hstart]),
                    np.concatenate([count, hcount]),
                    np.concatenate([split, hsplit]),
                    np.concatenate([child_active[split], child_h]),
                )
            )
            hstart, hcount = both[srt], np.concatenate([e_count, h_count])[srt]
            depth += 1
            if len(count):
                # side of every active primitive, then the stable partition into the next level's nodes
                box, ids, gstart, count = self._partition(box, ids, gstart, count, sp)
        return levels, _Frontier(box, ids, gstart, count, hstart, hcount, depth)

    def _choose_splits(self, box, ids, count, depth) -> tuple[np.ndarray, np.ndarray, _Splits]:
        """How each active node splits: by its best SAH bin, or not at all (a leaf), or it enters
        halving (its primitives Morton-sorted in `box` and `ids`, which are returned)."""
        max_leaf, bins, samples, small, leaf_cap = self.max_leaf, self.bins, self.samples, self.small, self.leaf_cap
        k = len(count)
        split = count > max_leaf
        if not k:
            empty = np.zeros(0, bool)
            return (
                box,
                ids,
                _Splits(split, empty, empty, None, None, np.zeros((0, 3), np.float32), np.zeros((0, 3), np.float32), None, None, None, None),
            )
        cmin = scale = None  # centroid bounds and bin scale, for nodes that split
        seg_start, seg_of = _segments(count)
        cen = box[0:3] + box[3:6]  # twice the centroid: only comparisons and ranges matter
        bmin = np.minimum.reduceat(box[0:3], seg_start, axis=1).T
        bmax = np.maximum.reduceat(box[3:6], seg_start, axis=1).T
        # halving from here keeps depth <= MAX_TREE_LEVELS: a halved subtree adds ceil(log2(count)) levels
        too_deep = depth + np.ceil(np.log2(np.maximum(count, 1))).astype(np.int64) + 1 >= MAX_TREE_LEVELS
        enter = split & ((count <= small) | too_deep)
        cand = np.flatnonzero(split & ~enter)
        axis = np.zeros(k, np.int64)
        cut = np.zeros(k, np.int64)  # primitives with bin <= cut go left
        if split.any():
            cmin = np.minimum.reduceat(cen, seg_start, axis=1).T
            cmax = np.maximum.reduceat(cen, seg_start, axis=1).T
            extent = cmax - cmin
        if len(cand):
            # small nodes use half the bins: their bin tables would outweigh their primitives
            node_bins = np.where(count > 2 * bins, bins, max(bins // 2, 2))
            scale = np.where(extent > 0, node_bins[:, None] / np.where(extent > 0, extent, 1), 0)
            scale = scale.astype(np.float32)
            for nb in np.unique(node_bins[cand]):
                c = cand[node_bins[cand] == nb]
                ok, axis[c], cut[c], cost = _best_splits(box, cen, seg_start, seg_of, count, c, cmin, scale, bmin, bmax, int(nb), samples)
                make_leaf = ok & (cost >= INTERSECT_COST * count[c]) & (count[c] <= leaf_cap)
                split[c[make_leaf]] = False
                enter[c[~ok]] = True
        binned = split & ~enter
        if enter.any():
            box, ids = _morton_sort(box, ids, cen, np.flatnonzero(np.repeat(enter, count)), seg_of, cmin, extent)
        return box, ids, _Splits(split, enter, binned, axis, cut, bmin, bmax, seg_start, cen, cmin, scale)

    def _partition(self, box, ids, gstart, count, sp: _Splits):
        """Each binned node's primitives split into its two children (left ones first, order kept
        within each side); the primitives of nodes leaving the active set go to their final slots."""
        order, fixed = self.order, self.fixed
        binned, enter, axis, cut, cmin, scale, cen, seg_start = (sp.binned, sp.enter, sp.axis, sp.cut, sp.cmin, sp.scale, sp.cen, sp.seg_start)
        k = len(count)
        n_binned = int(binned.sum())
        # side of every active primitive: True = left (primitives of leaves and entering nodes
        # count as left too, and go to the tail)
        n = len(ids)
        i = np.arange(n, dtype=np.int64)
        per_prim = partial(np.repeat, repeats=count)  # a per-node value for each primitive (faster than a[seg_of])
        done = ~per_prim(binned)
        if n_binned:
            rows = np.take(cen.ravel(), per_prim(axis * n) + i)  # centroid along the node's split axis
            kk = np.arange(k)
            rows -= per_prim(cmin[kk, axis])
            rows *= per_prim(scale[kk, axis])
            # the binning of _best_splits, floor(rows) <= cut, for rows >= 0 and cut < bins - 1
            go_left = rows < per_prim((cut + 1).astype(np.float32))
            go_left |= done
        else:
            go_left = np.ones(n, bool)

        # stable partition within each node: left primitives, then right ones; the primitives of
        # nodes leaving the active set, in node order, at the tail
        left_incl = np.cumsum(go_left)
        before = np.concatenate([[0], left_incl])[seg_start]
        n_left = np.concatenate([[0], left_incl])[seg_start + count] - before
        s = np.flatnonzero(binned)
        new_count = np.stack([n_left[s], count[s] - n_left[s]], axis=1).ravel()
        new_start, _ = _segments(new_count)
        n_keep = int(new_count.sum())
        leaving = ~binned
        tail_start = n_keep + np.cumsum(count * leaving) - count * leaving
        base_left = tail_start - before
        base_left[s] = new_start[0::2] - before[s]
        base_right = np.zeros(k, np.int64)
        base_right[s] = new_start[1::2] - seg_start[s] + before[s]
        dest = np.where(go_left, left_incl - 1 + per_prim(base_left), i - left_incl + per_prim(base_right))
        perm = np.empty(n, np.int64)
        perm[dest] = i
        ids = np.take(ids, perm)
        if n_keep < n:  # final slots of the primitives leaving the active set
            slot = np.repeat(gstart[leaving] - (tail_start[leaving] - n_keep), count[leaving]) + np.arange(n - n_keep)
            order[slot] = ids[n_keep:]
            if enter.any():
                tail = perm[n_keep:]
                for d in range(6):
                    fixed[d, slot] = box[d, tail]
        box = np.take(box, perm[:n_keep], axis=1)
        ids = ids[:n_keep]
        gstart = np.stack([gstart[s], gstart[s] + n_left[s]], axis=1).ravel()
        return box, ids, gstart, new_count


def _sah_levels(lo, hi, max_leaf, bins, samples, small):
    """The binned SAH build's levels (see _SahBuild) and the primitive order."""
    n_total = len(lo)
    build = _SahBuild(n_total, max_leaf, bins, samples, small)
    root = _Frontier(
        np.ascontiguousarray(np.concatenate([lo, hi], axis=1).T),
        np.arange(n_total, dtype=np.int32),
        np.zeros(1, np.int64),
        np.array([n_total], np.int64),
        np.zeros(0, np.int64),
        np.zeros(0, np.int64),
        1,
    )
    if n_total < PARALLEL_ABOVE:
        return build.grow(root, max_levels=MAX_TREE_LEVELS + 1)[0], build.order
    # the top levels here; then two groups of whole subtrees, with about half the primitives
    # each, grow in two threads (numpy releases the GIL in its array loops)
    levels, top = build.grow(root, max_levels=3)
    if len(top.count) < 2 or len(top.hcount):
        return levels + build.grow(top, max_levels=MAX_TREE_LEVELS + 1)[0], build.order
    cum = np.cumsum(top.count)
    g = int(np.clip(np.argmin(np.abs(cum - n_total / 2)) + 1, 1, len(top.count) - 1))  # nodes in the first group
    half = int(cum[g - 1])
    groups = [
        replace(top, box=np.ascontiguousarray(top.box[:, :half]), ids=top.ids[:half], start=top.start[:g], count=top.count[:g]),
        replace(top, box=np.ascontiguousarray(top.box[:, half:]), ids=top.ids[half:], start=top.start[g:], count=top.count[g:]),
    ]
    with ThreadPoolExecutor(2) as pool:
        first, second = pool.map(lambda group: build.grow(group, MAX_TREE_LEVELS + 1)[0], groups)
    return levels + _merge_levels(first, second), build.order


def _merge_levels(first: list[_Level], second: list[_Level]) -> list[_Level]:
    """Levels of two groups of subtrees side by side: the first group's nodes, then the second's."""
    merged = []
    for d in range(max(len(first), len(second))):
        a = first[d] if d < len(first) else None
        b = second[d] if d < len(second) else None
        if a is None or b is None:  # one subtree has ended: the other's child indices stay valid
            merged.append(a or b)
            continue
        below = len(first[d + 1].count) if d + 1 < len(first) else 0
        merged.append(
            _Level(
                np.concatenate([a.bmin, b.bmin]),
                np.concatenate([a.bmax, b.bmax]),
                np.concatenate([a.start, b.start]),
                np.concatenate([a.count, b.count]),
                np.concatenate([a.split, b.split]),
                np.concatenate([a.child, b.child + below]),
            )
        )
    return merged


def _morton_sort(box, ids, cen, prims, seg_of, cmin, extent):
    """Sort the primitives at positions `prims` (whole segments) by node, then Morton code."""
    node = seg_of[prims]
    scale = np.where(extent > 0, 1023.0 / np.where(extent > 0, extent, 1), 0)
    code = np.zeros(len(prims), np.int64)
    cp = np.take(cen, prims, axis=1)
    for a in range(3):
        q = ((cp[a] - cmin[node, a]) * scale[node, a]).astype(np.int64)
        code |= _spread_bits(np.clip(q, 0, 1023)) << (2 - a)
    srt = np.argsort(node.astype(np.int64) << 30 | code, kind="stable")
    src = prims[srt]
    box[:, prims] = np.take(box, src, axis=1)
    ids[prims] = ids[src]
    return box, ids


def _spread_bits(v):
    """Insert two zero bits between each of the low 10 bits of v (Morton interleave)."""
    v = (v | (v << 16)) & 0x030000FF
    v = (v | (v << 8)) & 0x0300F00F
    v = (v | (v << 4)) & 0x030C30C3
    return (v | (v << 2)) & 0x09249249


def _best_splits(box, cen, seg_start, seg_of, count, cand, cmin, scale, bmin, bmax, bins, samples):
    """Best binned-SAH split of each candidate node, over all three axes.

    Returns (ok, axis, cut, cost) per candidate; ok is False where no bin split separates the
    centroids (they all fall into one bin on every axis).  Bin tables are laid out bin-major,
    (bins, 3 * nc) with column 3 * node + axis, so the sweeps run over long contiguous rows.
    """
    nc = len(cand)
    m = 3 * nc
    c_count = count[cand]
    take = np.minimum(c_count, samples)
    # primitives to bin: all of a small node, an evenly strided sample of a big one
    if (take == c_count).all():
        rank = np.full(len(count), -1, np.int64)
        rank[cand] = np.arange(nc)
        per_prim = np.repeat(rank, count)
        p = np.flatnonzero(per_prim >= 0)
        which = per_prim[p]
    else:
        _, which = _segments(take)
        j = np.arange(len(which)) - np.repeat(np.cumsum(take) - take, take)
        p = seg_start[cand][which] + (j * c_count[which]) // take[which]
    keys = np.empty((3, len(p)), np.int64)
    cp = np.take(cen, p, axis=1)
    cp -= np.take(cmin[cand].T, which, axis=1)
    cp *= np.take(scale[cand].T, which, axis=1)
    col = which * 3
    for a in range(3):
        b = cp[a].astype(np.int64)
        np.minimum(b, bins - 1, out=b)
        b *= m
        b += col + a
        keys[a] = b
    n_bin = np.bincount(keys.ravel(), minlength=bins * m).reshape(bins, m).astype(np.float32)
    # per-bin bounds: rows lo.xyz, -hi.xyz so that one ufunc (minimum) does all six
    bb = np.full((6, bins * m), np.inf, np.float32)
    bp = np.take(box, p, axis=1)
    bp[3:] *= -1
    for a in range(3):
        for d in range(6):
            np.minimum.at(bb[d], keys[a], bp[d])
    bb = bb.reshape(6, bins, m)
    # sweep: bounds of bins [0..i] (left of cut i) and [i+1..] (right); a loop over the bins is
    # much faster than ufunc.accumulate along a middle axis
    left = np.empty((6, bins - 1, m), np.float32)
    right = np.empty((6, bins - 1, m), np.float32)
    left[:, 0], right[:, -1] = bb[:, 0], bb[:, -1]
    for i in range(1, bins - 1):
        np.minimum(left[:, i - 1], bb[:, i], out=left[:, i])
        np.minimum(right[:, -i], bb[:, -1 - i], out=right[:, -1 - i])
    n_l = np.cumsum(n_bin, axis=0)[:-1]
    n_r = n_bin.sum(axis=0) - n_l

    def area(t):  # half surface area from rows lo.xyz, -hi.xyz; empty (inf) boxes give 0 * 0
        e = np.maximum(-(t[3:6] + t[0:3]), 0)
        return e[0] * e[1] + e[1] * e[2] + e[2] * e[0]

    with np.errstate(invalid="ignore", over="ignore"):  # empty bins: inf - inf; huge scenes: inf areas
        sah = area(left) * n_l + area(right) * n_r  # (bins - 1, m)
    sah[(n_l == 0) | (n_r == 0)] = np.inf
    cut = np.argmin(sah, axis=0)  # best cut per (node, axis) column
    per_axis = np.take_along_axis(sah, cut[None], axis=0).reshape(nc, 3)
    axis = np.argmin(per_axis, axis=1)
    best_sah = per_axis[np.arange(nc), axis].astype(np.float64)
    cut = cut.reshape(nc, 3)[np.arange(nc), axis]
    weight = c_count / take  # sampled counts stand for the whole node
    node_area = half_area(bmin[cand].astype(np.float64), bmax[cand].astype(np.float64))
    node_area = np.where(node_area > 0, node_area, 1.0)
    cost = TRAVERSAL_COST + INTERSECT_COST * weight * best_sah / node_area
    return np.isfinite(best_sah), axis, cut, cost


# ---------------------------------------------------------------- binned SAH on the device
TOP_TASKS = 256  # the top levels are split one node per work-item until nodes hold about n / TOP_TASKS primitives
TOP_MIN = 4096  # ... and at least this many; smaller nodes build their whole subtree in one work-item


def _sah_device(lo, hi, max_leaf, bins, samples, halving_below):
    """Binned SAH in kernels/bvh_build.cl: the top levels one launch per level (a node per work-item),
    then every remaining subtree in one launch (a subtree per work-item).  Returns (nodes, prim_order)."""
    import pyopencl as cl

    from ..device import get_device

    dev = get_device()
    defines = dict(BINS=bins, BUILD_STACK=STACK_SIZE + 2)
    split_level = dev.kernel("bvh_build.cl", "split_level", defines)
    build_subtree = dev.kernel("bvh_build.cl", "build_subtree", defines)
    n = len(lo)
    params = [np.int32(v) for v in (max_leaf, 4 * max_leaf, samples, halving_below, MAX_TREE_LEVELS)]
    box = np.empty((n, 8), np.float32)  # (lo, id bits), (hi, 0) per primitive
    box[:, 0:3], box[:, 4:7], box[:, 7] = lo, hi, 0
    box[:, 3] = np.arange(n, dtype=np.int32).view(np.float32)
    mf = cl.mem_flags
    box_buf = cl.Buffer(dev.context, mf.READ_WRITE | mf.USE_HOST_PTR, hostbuf=box)
    cen = lo + hi
    root = np.zeros((4, 4), np.float32)
    root[0, :3], root[1, :3], root[2, :3], root[3, :3] = lo.min(0), hi.max(0), cen.min(0), cen.max(0)

    # top levels: node records (bounds, start, count, level, first child or -1), breadth-first
    t_bounds, t_start, t_count, t_child = [root], [0], [n], [-1]
    threshold = max(n // TOP_TASKS, TOP_MIN)
    level, depth = [0], 1
    subtrees = []  # top nodes whose subtrees build_subtree grows
    while level:
        big = [i for i in level if t_count[i] > threshold]
        subtrees += [i for i in level if t_count[i] <= threshold]
        if not big:
            break
        task = np.array([[t_start[i], t_count[i], depth, 0] for i in big], np.int32)
        bounds = np.stack([t_bounds[i] for i in big])
        n_first = np.empty(len(big), np.int32)
        child_bounds = np.empty((2 * len(big), 4, 4), np.float32)
        nf_buf, cb_buf = dev.empty(n_first.nbytes), dev.empty(child_bounds.nbytes)
        split_level(
            dev.queue, (len(big),), (1,), box_buf, dev.to_device(task), dev.to_device(bounds), np.int32(len(big)), *params, nf_buf, cb_buf
        )
        cl.enqueue_copy(dev.queue, n_first, nf_buf)
        cl.enqueue_copy(dev.queue, child_bounds, cb_buf)
        level, depth = [], depth + 1
        for j, i in enumerate(big):
            if n_first[j] == 0:  # a leaf
                continue
            t_child[i] = len(t_start)
            for side, (s, c) in enumerate(((t_start[i], n_first[j]), (t_start[i] + n_first[j], t_count[i] - n_first[j]))):
                level.append(len(t_start))
                t_bounds.append(child_bounds[2 * j + side])
                t_start.append(s)
                t_count.append(int(c))
                t_child.append(-1)
    # node depth of each top node, for the subtree tasks
    t_depth = [1] * len(t_start)
    for i, c in enumerate(t_child):
        if c >= 0:
            t_depth[c] = t_depth[c + 1] = t_depth[i] + 1

    # the subtrees, biggest first (one work-item each; node slots 2 * start .. 2 * (start + count) - 1)
    subtrees.sort(key=lambda i: -t_count[i])
    task = np.array([[t_start[i], t_count[i], t_depth[i], 2 * t_start[i]] for i in subtrees], np.int32).reshape(-1, 4)
    bounds = np.stack([t_bounds[i] for i in subtrees])
    scratch = np.empty((2 * n, 8), np.float32)
    scratch_buf = cl.Buffer(dev.context, mf.READ_WRITE | mf.USE_HOST_PTR, hostbuf=scratch)
    n_nodes = np.empty(len(subtrees), np.int32)
    nn_buf = dev.empty(n_nodes.nbytes)
    build_subtree(
        dev.queue, (len(subtrees),), (1,), box_buf, dev.to_device(task), dev.to_device(bounds), np.int32(len(subtrees)), *params, scratch_buf, nn_buf
    )
    cl.enqueue_copy(dev.queue, n_nodes, nn_buf)
    dev.sync_to_host(scratch_buf, scratch)
    dev.sync_to_host(box_buf, box)

    # depth-first layout: sizes bottom-up, preorder positions top-down, subtrees copied in and their offsets moved
    size = [1] * len(t_start)
    sub_of = {i: s for s, i in enumerate(subtrees)}
    for i in range(len(t_start) - 1, -1, -1):
        if i in sub_of:
            size[i] = int(n_nodes[sub_of[i]])
        elif t_child[i] >= 0:
            size[i] = 1 + size[t_child[i]] + size[t_child[i] + 1]
    nodes = np.empty(size[0], NODE_DTYPE)
    flat = nodes.view(np.float32).reshape(-1, 8)
    words = nodes.view(np.int32).reshape(-1, 8)
    pre = [0] * len(t_start)
    for i in range(len(t_start)):
        p = pre[i]
        if i in sub_of:
            s = sub_of[i]
            m, base = int(n_nodes[s]), 2 * t_start[i]
            flat[p : p + m] = scratch[base : base + m]
            w = words[p : p + m]
            interior = w[:, 7] == 0
            w[interior, 3] += p - base
            continue
        c = t_child[i]
        flat[p, 0:3], flat[p, 4:7] = t_bounds[i][0, :3], t_bounds[i][1, :3]
        if c < 0:
            words[p, 3], words[p, 7] = t_start[i], t_count[i]
        else:
            pre[c], pre[c + 1] = p + 1, p + 1 + size[c]
            words[p, 3], words[p, 7] = pre[c + 1], 0
    return nodes, box[:, 3].view(np.int32).copy()
