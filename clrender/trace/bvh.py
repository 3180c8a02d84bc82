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

Builders:

* ``sah`` -- binned surface area heuristic, built on the OpenCL device
  (kernels/bvh_build.cl; clrender.device.get_device(), the fastest CPU driver by default):
  ``bins`` bins over the centroid bounds of each node, along all three axes,
  best cut by SAH cost.  Nodes larger than ``sah_samples`` primitives evaluate
  their bins on an evenly strided sample of that many primitives (the cut then
  partitions all of them); nodes of at most ``2 * bins`` primitives use
  ``bins // 2`` bins.  A node becomes a leaf when it holds at most
  ``max_leaf_size`` primitives, or when no cut is cheaper than the leaf and it
  holds at most ``4 * max_leaf_size``, except that a primitive whose box has at
  least ``LARGE_SHARE`` of the root box's surface area shares its leaf with at
  most one other.  A node of at most ``halving_below``
  primitives (none by default), one whose centroids all fall in one bin (e.g.
  they coincide), or one too deep to finish by SAH within MAX_TREE_LEVELS is
  split in halves (``count // 2`` to the first child) along its widest centroid
  axis.  The top levels split one node per work-item, one launch per level;
  below about ``n / TOP_TASKS`` primitives each work-item builds a whole
  subtree.  Every work-item works alone on its own range of primitives, so the
  tree does not depend on scheduling: the same input gives the same tree.
* ``median`` -- the object-median split, in numpy (vectorised: the tree grows one level
  at a time, every node of a level handled at once, then the breadth-first tree
  is renumbered depth-first): primitives sorted by centroid x, every node split
  into halves (the first child gets ``count // 2``), leaves of at most
  ``max_leaf_size``.

Every tree is at most ``max_levels`` levels deep (``MAX_TREE_LEVELS`` by default, which the
kernels' default traversal stacks hold: clrender.trace.knobs): SAH nodes switch to halving early enough.
"""

from __future__ import annotations

import threading
import time
from dataclasses import dataclass

import numpy as np

from ..errors import UsageError
from ..layout import BUILD_BOUNDS_DTYPE, BUILD_PRIM_DTYPE, BUILD_RULES_DTYPE, BUILD_TASK_DTYPE, BVH_NODE_DTYPE, SUBTREE_MOVE_DTYPE
from .knobs import BUILD_STACK, DEFAULT_KNOBS, MAX_TREE_LEVELS_LIMIT

NODE_DTYPE = BVH_NODE_DTYPE  # the kernels' BvhNode (clrender/layout.py)
BUILDERS = ("sah", "median")
MAX_TREE_LEVELS = DEFAULT_KNOBS.max_tree_levels  # levels, root included (a Tracer passes its knobs' value)
SAH_SAMPLES = 1024  # nodes larger than this bin a strided sample of this many primitives
HALVING_BELOW = 0  # SAH nodes of at most this many primitives are split in halves (0: none by size)
MAX_BINS = 64  # SAH bins per axis at most (the kernel keeps 3 x bins bin records per work-item)
TOP_TASKS = 256  # SAH nodes of more than n / TOP_TASKS primitives split one per work-item, one launch per level ...
TOP_MIN = 4096  # ... and of more than this many; smaller ones build their whole subtree in one work-item
LOAD_CHUNKS = 64  # work-items that make the SAH build's primitive records
MAX_SAH_PRIMS = 2**27 - 1  # the kernels index node and record words with int32 (16 words per primitive)
_DEVICE_BUILD = threading.Lock()  # one SAH build on the device at a time per process
TRAVERSAL_COST = 1.0  # SAH cost of visiting an interior node, relative to one primitive test
INTERSECT_COST = 1.0
# a primitive whose box has at least this share of the root box's surface area is large (a wall, a floor): it shares a
# leaf with at most one other primitive (kernels/bvh_build.cl holds_large)
LARGE_SHARE = 1.0 / 16.0


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


def _area_unit(side: np.ndarray) -> np.float32:
    """1 / the longest of float32 box sides, as kernels/bvh_build.cl's area_unit computes it (1 where that is not a
    positive finite float): box sides times it are at most 1, and scaling a scene by a power of two scales it exactly."""
    longest = np.float32(side.max())
    with np.errstate(divide="ignore", over="ignore"):
        unit = np.float32(1) / longest if longest > 0 else np.float32(1)
    return unit if np.isfinite(unit) and unit > 0 else np.float32(1)


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
    max_levels: int = MAX_TREE_LEVELS,
    top_tasks: int = TOP_TASKS,
    top_min: int = TOP_MIN,
    device=None,
) -> BVH:
    """Build a BVH over N primitives given their bounds lo, hi (each (N, 3)), at most `max_levels`
    deep; the SAH builder runs on `device` (default: clrender's device).  `top_tasks` and `top_min`
    choose the nodes split one per work-item, those of more than max(n // top_tasks, top_min)
    primitives; the tree does not depend on them."""
    start = time.perf_counter()
    if builder not in BUILDERS:
        raise UsageError(f"unknown BVH builder {builder!r}; allowed: {', '.join(BUILDERS)}")
    if int(max_leaf_size) < 1:
        raise UsageError(f"max_leaf_size {max_leaf_size}; allowed: 1 or more")
    if not 2 <= int(bins) <= MAX_BINS:
        raise UsageError(f"bins {bins}; allowed: 2 to {MAX_BINS}")
    if not 2 <= int(sah_samples) < 2**31:
        raise UsageError(f"sah_samples {sah_samples}; allowed: 2 or more")
    if not 0 <= int(halving_below) < 2**31:
        raise UsageError(f"halving_below {halving_below}; allowed: 0 or more")
    if not 2 <= int(max_levels) <= MAX_TREE_LEVELS_LIMIT:
        raise UsageError(f"max_levels {max_levels}; allowed: 2 to {MAX_TREE_LEVELS_LIMIT}")
    if int(top_tasks) < 1 or int(top_min) < 1:
        raise UsageError(f"top_tasks {top_tasks} and top_min {top_min}; allowed: 1 or more")
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
    if builder == "sah" and n > MAX_SAH_PRIMS:
        raise UsageError(f"{n} primitives for the sah builder; allowed: at most {MAX_SAH_PRIMS} (or builder 'median')")
    if builder == "median":
        levels, order = _median_levels(lo, hi, int(max_leaf_size))
        nodes = _depth_first(levels)
    else:
        with _DEVICE_BUILD:  # the kernel objects and their arguments are shared by every caller
            params = (min(int(max_leaf_size), 2**28), int(bins), int(sah_samples), int(halving_below), int(max_levels))
            nodes, order = _sah_device(lo, hi, *params, subtree_size=max(n // int(top_tasks), int(top_min)), device=device)
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


# ---------------------------------------------------------------- median
def _median_levels(lo, hi, max_leaf):
    """The median builder: one sort by centroid x, then every node splits its range in halves."""
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


# ---------------------------------------------------------------- binned SAH (kernels/bvh_build.cl)
@dataclass
class _SahRun:
    """What the launches of one device SAH build share."""

    dev: object  # clrender.device.Device
    knl: dict  # the bvh_build.cl kernels by name
    rules: np.ndarray  # the BuildRules record every split_level and build_subtree launch takes
    n: int  # primitives
    chunk: int  # primitives per load_prims / prim_order work-item
    n_chunks: int
    box: object = None  # the primitive records on the device (load_prims)


@dataclass
class _TopNodes:
    """The top levels, breadth-first: each top node's bounds, first slot, primitives, level, first child (-1: none)."""

    bounds: list
    start: list
    count: list
    level: list
    child: list

    def add(self, bounds, start, count, level) -> int:
        """Append a childless node; returns its index."""
        self.bounds.append(bounds)
        self.start.append(int(start))
        self.count.append(int(count))
        self.level.append(level)
        self.child.append(-1)
        return len(self.start) - 1


def _sah_device(lo, hi, max_leaf, bins, samples, halving_below, max_levels, *, subtree_size, device):
    """The binned SAH build on the OpenCL device: returns (nodes, prim_order).

    Top levels: one split_level launch per level, a node per work-item, until every node holds at
    most `subtree_size` primitives (about n / TOP_TASKS, so that both cores stay busy to the end, and
    no fewer than TOP_MIN); then one build_subtree launch, a whole subtree per
    work-item (biggest first), written to scratch node slots 2 * first slot onwards; then
    place_subtrees copies them to their depth-first places.  The few top nodes are laid out here.
    """
    from ..device import get_device

    dev = device if device is not None else get_device()
    defines = dict(BINS=bins, BUILD_STACK=BUILD_STACK)
    knl = {name: dev.kernel("bvh_build.cl", name, defines) for name in ("load_prims", "split_level", "build_subtree", "place_subtrees", "prim_order")}
    n = len(lo)
    rules = np.zeros((), BUILD_RULES_DTYPE)
    for name, value in dict(max_leaf=max_leaf, leaf_cap=4 * max_leaf, samples=samples, halving_below=halving_below, max_levels=max_levels).items():
        rules[name] = value
    dev.check_fits(2 * n * NODE_DTYPE.itemsize, f"a BVH over {n} primitives")  # the scratch nodes, the biggest buffer
    chunk = -(-n // LOAD_CHUNKS)
    run = _SahRun(dev, knl, rules, n, chunk, -(-n // chunk))
    root = _load_prims(run, lo, hi)
    rules["root_unit"] = unit = _area_unit(root["bmax"][:3] - root["bmin"][:3])
    large = LARGE_SHARE * half_area(root["bmin"][:3] * unit, root["bmax"][:3] * unit)
    rules["large_area"] = large if large > 0 else np.inf  # a root of no area: no primitive is large
    top, subtrees = _top_levels(run, root, subtree_size)
    subtrees.sort(key=lambda i: -top.count[i])  # every subtree in one work-item, biggest first
    if not subtrees:  # the root is a leaf (more than subtree_size primitives, at most max_leaf)
        nodes = np.zeros(1, NODE_DTYPE)
        nodes["bmin"][0], nodes["bmax"][0], nodes["count"][0] = root["bmin"][:3], root["bmax"][:3], n
        return nodes, np.arange(n, dtype=np.int32)
    scratch_buf, first_node, n_nodes = _build_subtrees(run, top, subtrees)
    return _sah_layout(run, top, subtrees, scratch_buf, first_node, n_nodes)


def _load_prims(run: _SahRun, lo, hi):
    """Make the primitive records (run.box), a chunk of primitives per work-item; returns the root's bounds."""
    import pyopencl as cl

    dev = run.dev
    run.box = dev.empty(run.n * BUILD_PRIM_DTYPE.itemsize)
    chunk_bounds = np.empty(run.n_chunks, BUILD_BOUNDS_DTYPE)
    cb_buf = dev.empty(chunk_bounds.nbytes)
    lo_buf, hi_buf = dev.to_device(lo), dev.to_device(hi)
    run.knl["load_prims"](dev.queue, (run.n_chunks,), (1,), lo=lo_buf, hi=hi_buf, n=run.n, chunk=run.chunk, box=run.box, chunk_bounds=cb_buf)
    cl.enqueue_copy(dev.queue, chunk_bounds, cb_buf)
    root = np.zeros(1, BUILD_BOUNDS_DTYPE)[0]  # the w lanes 0: load_prims' primitive id bits have no meaning here
    for name, merge in (("bmin", np.min), ("bmax", np.max), ("cmin", np.min), ("cmax", np.max)):
        root[name][:3] = merge(chunk_bounds[name][:, :3], axis=0)
    return root


def _top_levels(run: _SahRun, root, big_enough):
    """Split the top nodes one level per launch until each holds at most `big_enough` primitives.

    Returns the top nodes and the indices of those whose whole subtree build_subtree grows.
    """
    top = _TopNodes([root], [0], [run.n], [1], [-1])
    level, subtrees = [0], []
    while level:
        subtrees += [i for i in level if top.count[i] <= big_enough]
        big = [i for i in level if top.count[i] > big_enough]
        if not big:
            break
        n_first, left, right = _split_level(run, top, big)
        level = []
        for j, i in enumerate(big):
            if n_first[j] == 0:  # a leaf
                continue
            top.child[i] = len(top.start)
            first, count, depth = top.start[i], top.count[i], top.level[i] + 1
            level.append(top.add(left[j], first, n_first[j], depth))
            level.append(top.add(right[j], first + n_first[j], count - n_first[j], depth))
    return top, subtrees


def _split_level(run: _SahRun, top: _TopNodes, big):
    """One split_level launch over the top nodes `big`: each one's first child's primitives and both children's bounds."""
    import pyopencl as cl

    dev = run.dev
    task = _tasks(big, top.start, top.count, top.level)
    n_first = np.empty(len(big), np.int32)
    left, right = np.empty(len(big), BUILD_BOUNDS_DTYPE), np.empty(len(big), BUILD_BOUNDS_DTYPE)
    nf_buf, left_buf, right_buf = dev.empty(n_first.nbytes), dev.empty(left.nbytes), dev.empty(right.nbytes)
    run.knl["split_level"](
        dev.queue,
        (len(big),),
        (1,),
        box=run.box,
        task=dev.to_device(task),
        bounds=dev.to_device(np.array([top.bounds[i] for i in big], BUILD_BOUNDS_DTYPE)),
        n_tasks=len(big),
        rules=run.rules,
        n_first=nf_buf,
        left_bounds=left_buf,
        right_bounds=right_buf,
    )
    cl.enqueue_copy(dev.queue, n_first, nf_buf)
    cl.enqueue_copy(dev.queue, left, left_buf)
    cl.enqueue_copy(dev.queue, right, right_buf)
    return n_first, left, right


def _build_subtrees(run: _SahRun, top: _TopNodes, subtrees):
    """One build_subtree launch, a subtree per work-item: returns the scratch nodes, each subtree's first scratch slot and its node count."""
    import pyopencl as cl

    dev = run.dev
    task = _tasks(subtrees, top.start, top.count, top.level)
    task["first_node"] = 2 * task["first"]  # scratch nodes: a subtree of c primitives has at most 2c - 1
    scratch_buf = dev.empty(2 * run.n * NODE_DTYPE.itemsize)
    n_nodes = np.empty(len(subtrees), np.int32)
    nn_buf = dev.empty(n_nodes.nbytes)
    run.knl["build_subtree"](
        dev.queue,
        (len(subtrees),),
        (1,),
        box=run.box,
        task=dev.to_device(task),
        bounds=dev.to_device(np.array([top.bounds[i] for i in subtrees], BUILD_BOUNDS_DTYPE)),
        n_tasks=len(subtrees),
        rules=run.rules,
        nodes=scratch_buf,
        n_nodes=nn_buf,
    )
    cl.enqueue_copy(dev.queue, n_nodes, nn_buf)
    return scratch_buf, task["first_node"], n_nodes


def _sah_layout(run: _SahRun, top: _TopNodes, subtrees, scratch_buf, first_node, n_nodes):
    """Depth-first layout: node counts bottom-up, preorder places top-down; the subtrees move there on the device."""
    dev = run.dev
    size = [1] * len(top.start)
    for s, i in enumerate(subtrees):
        size[i] = int(n_nodes[s])
    for i in range(len(top.start) - 1, -1, -1):
        if top.child[i] >= 0:
            size[i] = 1 + size[top.child[i]] + size[top.child[i] + 1]
    place = [0] * len(top.start)
    for i, c in enumerate(top.child):
        if c >= 0:
            place[c], place[c + 1] = place[i] + 1, place[i] + 1 + size[c]
    nodes = np.empty(size[0], NODE_DTYPE)
    nodes_buf = dev.host_buffer(nodes)
    move = np.empty(len(subtrees), SUBTREE_MOVE_DTYPE)
    move["source"], move["target"], move["nodes"] = first_node, [place[i] for i in subtrees], [size[i] for i in subtrees]
    move_buf = dev.to_device(move)
    run.knl["place_subtrees"](dev.queue, (len(subtrees),), (1,), scratch=scratch_buf, move=move_buf, n_moves=len(subtrees), nodes=nodes_buf)
    order = np.empty(run.n, np.int32)
    order_buf = dev.host_buffer(order)
    run.knl["prim_order"](dev.queue, (run.n_chunks,), (1,), box=run.box, n=run.n, chunk=run.chunk, order=order_buf)
    dev.sync_to_host(nodes_buf, nodes)
    dev.sync_to_host(order_buf, order)
    _top_nodes_to(nodes, top, subtrees, place)
    return nodes, order


def _top_nodes_to(nodes, top: _TopNodes, subtrees, place):
    """Write the top nodes above the subtrees to their depth-first places."""
    in_subtree = set(subtrees)
    for i in range(len(top.start)):
        if i in in_subtree:
            continue
        p, c = place[i], top.child[i]
        nodes["bmin"][p], nodes["bmax"][p] = top.bounds[i]["bmin"][:3], top.bounds[i]["bmax"][:3]
        nodes["offset"][p], nodes["count"][p] = (top.start[i], top.count[i]) if c < 0 else (place[c + 1], 0)


def _tasks(which, start, count, level) -> np.ndarray:
    """The BuildTask records of the top nodes `which` (first_node 0)."""
    task = np.zeros(len(which), BUILD_TASK_DTYPE)
    task["first"], task["count"], task["level"] = [start[i] for i in which], [count[i] for i in which], [level[i] for i in which]
    return task
