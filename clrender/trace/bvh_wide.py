"""Wide BVH: the binary tree of clrender.trace.bvh collapsed into nodes of up to WIDTH children.

One ray tests all children of a node at once with float4 / float8 operations
(the slab test of kernels/intersect.h, lane by lane), then visits the hit ones
nearest first.  A node is one WideNode4 / WideNode8 record (clrender/layout.py,
128 or 256 bytes), each field WIDTH lanes, one per child::

    bounds[0..5]  lo_x, hi_x, lo_y, hi_y, lo_z, hi_z   bounds of each child (float32)
    child         interior child: its wide node index; leaf child: first slot (in the kernels'
                  buffer, tree_buffer: its first leaf block)
    count         interior child: 0; leaf child: number of slots (> 0); empty lane: -1

Empty lanes get the box lo = +inf, hi = -inf, which the slab test misses for
every ray (each slab's entry is +inf and its exit -inf, never NaN for a finite
origin and nonzero direction), so the kernels need not read their count.  Node 0 is the root; a binary tree that is a single leaf
becomes a root with that leaf in lane 0.  Leaves and primitive slots are the
binary tree's, unchanged (``prim_order`` stays valid).

Collapse rule (as Embree's BVH4 from a binary SAH tree): a wide node starts
with the two children of its binary node, then repeatedly replaces the
interior child of largest surface area by its two children until it has
WIDTH children or only leaves.  Vectorised over all nodes of a level.  A wide
node is never deeper than the binary node it came from, so wide trees keep the
binary depth bound (MAX_TREE_LEVELS) and the kernels' stack bound (TraceKnobs.wide_stack_size).
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from ..device import aligned_zeros
from ..layout import BLOCK_LANES, LEAF_BLOCK_DTYPE, WIDE_NODE_DTYPES
from .bvh import BVH, half_area

WIDTHS = (2, 4, 8)  # 2: the binary tree as is


@dataclass
class WideBVH:
    nodes: np.ndarray  # (n_nodes,) layout.WIDE_NODE_DTYPES[width] records
    prim_order: np.ndarray  # int32, the binary tree's slot order
    width: int
    build_seconds: float  # binary build + collapse
    binary: BVH

    @property
    def node_count(self) -> int:
        return len(self.nodes)

    @property
    def child(self) -> np.ndarray:
        return self.nodes["child"]  # (n_nodes, width)

    @property
    def count(self) -> np.ndarray:
        return self.nodes["count"]  # (n_nodes, width)

    @property
    def lo(self) -> np.ndarray:
        return self.nodes["bounds"][:, 0::2]  # (n_nodes, axis, width)

    @property
    def hi(self) -> np.ndarray:
        return self.nodes["bounds"][:, 1::2]  # (n_nodes, axis, width)

    @property
    def depth(self) -> int:
        """Levels on the longest root-to-leaf-node path (leaves live in their parent's lanes)."""
        frontier, levels = np.zeros(1, np.int64), 0
        while len(frontier):  # one level of wide nodes at a time
            interior = self.count[frontier] == 0
            frontier, levels = self.child[frontier][interior].astype(np.int64), levels + 1
        return levels

    def stats(self) -> dict:
        return dict(
            builder=self.binary.builder,
            width=self.width,
            nodes=self.node_count,
            depth=self.depth,
            sah_cost=self.sah_cost(),
            binary_sah_cost=self.binary.sah_cost(),
            build_s=self.build_seconds,
        )

    def sah_cost(self, traversal_cost: float = 1.0, intersect_cost: float = 1.0) -> float:
        """Expected cost of a ray hitting the root, as BVH.sah_cost: every wide node visited costs
        traversal_cost (its lanes are tested at once), every leaf intersect_cost per primitive."""
        lo = self.lo.astype(np.float64).transpose(0, 2, 1)
        hi = self.hi.astype(np.float64).transpose(0, 2, 1)
        valid = self.count >= 0
        area = np.where(valid, half_area(lo, hi), 0.0)
        root = half_area(lo[0][valid[0]].min(0), hi[0][valid[0]].max(0))
        rel = area / root if root > 0 else valid.astype(np.float64)
        interior = (self.count == 0).astype(np.float64)
        leaf_prims = np.where(self.count > 0, self.count, 0)
        return float(traversal_cost + (rel * (traversal_cost * interior + intersect_cost * leaf_prims)).sum())


def collapse(bvh: BVH, width: int = 4) -> WideBVH:
    """Collapse a binary BVH into a wide one (see the module docstring)."""
    start = time.perf_counter()
    if width not in WIDTHS or width == 2:
        raise ValueError(f"width {width}; allowed: 4 or 8")
    bn = bvh.nodes
    n_bin = len(bn)
    count = bn["count"].astype(np.int64)
    offset = bn["offset"].astype(np.int64)
    interior = count == 0
    if n_bin == 1:  # a lone root: a leaf, or the empty tree (count 0 and no primitives)
        interior[:] = False
    area = half_area(bn["bmin"].astype(np.float64), bn["bmax"].astype(np.float64))

    score = np.append(np.where(interior, area, -1.0), -1.0)  # index -1 (an empty lane) reads the last entry
    levels = []  # per level: (binary ids of the wide nodes' lanes, (k, width) with -1 for empty)
    if n_bin == 1:
        lanes = np.full((1, width), -1, np.int64)
        lanes[0, 0] = 0
        levels.append(lanes)
        frontier = np.zeros(0, np.int64)
    else:
        frontier = np.zeros(1, np.int64)  # binary nodes that become wide nodes
    while len(frontier):
        k = len(frontier)
        lanes = np.full((k, width), -1, np.int64)
        lanes[:, 0], lanes[:, 1] = frontier + 1, offset[frontier]
        rows = np.arange(k)
        for filled in range(2, width):
            lane_area = score[lanes]  # -1 for leaves and empty lanes: they cannot be opened
            pick = np.argmax(lane_area, axis=1)
            grow = lane_area[rows, pick] >= 0
            r, p = rows[grow], pick[grow]
            b = lanes[r, p]
            lanes[r, p] = b + 1
            lanes[r, filled] = offset[b]
        levels.append(lanes)
        flat = lanes[lanes >= 0]
        frontier = flat[interior[flat]]

    # wide node indices: breadth-first, in order of appearance
    n_wide = sum(len(lv) for lv in levels)
    nodes = np.zeros(n_wide, WIDE_NODE_DTYPES[width])
    bounds, child, count_lanes = nodes["bounds"], nodes["child"], nodes["count"]
    wide_of = np.full(n_bin, -1, np.int64)
    # assign wide indices level by level: a level's interior lanes become the next level's nodes
    wide_of[0] = 0
    base = 0
    for lv in levels:
        flat = lv[lv >= 0]
        nxt = flat[interior[flat]]
        wide_of[nxt] = base + len(lv) + np.arange(len(nxt))
        base += len(lv)
    # per binary node, what a lane pointing at it holds; one extra last entry for empty lanes (-1)
    lo_of = np.vstack([bn["bmin"], np.full((1, 3), np.inf, np.float32)])
    hi_of = np.vstack([bn["bmax"], np.full((1, 3), -np.inf, np.float32)])
    child_of = np.append(np.where(interior, wide_of, offset), 0)
    count_of = np.append(np.where(interior, 0, count), -1)
    base = 0
    for lv in levels:
        sl = slice(base, base + len(lv))
        bounds[sl, 0::2] = lo_of[lv].transpose(0, 2, 1)
        bounds[sl, 1::2] = hi_of[lv].transpose(0, 2, 1)
        child[sl] = child_of[lv]
        count_lanes[sl] = count_of[lv]
        base += len(lv)
    if n_bin == 1 and count[0] == 0:  # the empty tree: no lanes at all
        bounds[0, 0::2, 0], bounds[0, 1::2, 0] = np.inf, -np.inf
        count_lanes[0, 0] = -1
    return WideBVH(nodes, bvh.prim_order, width, bvh.build_seconds + time.perf_counter() - start, bvh)


def leaf_blocks(wide: WideBVH, slots: np.ndarray, out: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Every leaf's primitives in leaf blocks of BLOCK_LANES (layout.LEAF_BLOCK_DTYPE), which the kernels
    test at once with float4 operations, leaf after leaf in the order of the tree's leaf lanes
    (wide.count > 0, row-major); and the index of each such leaf's first block.

    `slots` are the primitive records in slot order (geometry.pack_slots).  A leaf of `count`
    primitives takes ceil(count / BLOCK_LANES) blocks, its slots in order, then empty lanes (slot -1);
    a sphere's lane holds -2 - slot and zero vertices.  The vertices are copied bit for bit from
    `slots`, so a block lane computes exactly what the one-primitive test computes from the record.
    `out`: LEAF_BLOCK_DTYPE records to fill (at least as many as the blocks; default: new ones);
    they are filled a chunk of blocks at a time, so the temporaries stay small."""
    leaf = wide.count > 0
    first, n = wide.child[leaf].astype(np.int64), wide.count[leaf].astype(np.int64)
    per_leaf = -(-n // BLOCK_LANES)
    first_block = np.concatenate([[0], np.cumsum(per_leaf)[:-1]]).astype(np.int64)
    total = int(per_leaf.sum())
    blocks = np.zeros(total, LEAF_BLOCK_DTYPE) if out is None else out[:total]
    owner_all = np.repeat(np.arange(len(n), dtype=np.int32), per_leaf)  # leaf of each block
    for a in range(0, total, BLOCK_CHUNK):
        owner = owner_all[a : a + BLOCK_CHUNK]
        lane = (np.arange(a, a + len(owner)) - first_block[owner])[:, None] * BLOCK_LANES + np.arange(BLOCK_LANES)
        slot = np.where(lane < n[owner, None], first[owner, None] + lane, -1)  # (chunk, lanes)
        rec = slots[np.maximum(slot, 0)]
        sphere = (slot >= 0) & (rec["sphere"] != 0)
        blank = (slot < 0) | sphere  # lanes without a triangle: zero vertices
        chunk = blocks[a : a + len(owner)]
        for vertex in ("v0", "v1", "v2"):
            chunk[vertex] = np.where(blank[..., None], np.float32(0), rec[vertex]).transpose(0, 2, 1)  # (block, axis, lane)
        chunk["slot"] = np.where(sphere, -2 - slot, slot)
    return blocks, first_block


BLOCK_CHUNK = 1 << 16  # leaf blocks filled at a time (their temporaries: a few MB)


def tree_buffer(wide: WideBVH, slots: np.ndarray) -> np.ndarray:
    """The bytes the kernels read as a wide tree (Geometry.nodes in kernels/intersect.h): its nodes,
    then from the first multiple of a LeafBlock's size on, its leaf blocks (leaf_blocks).  A leaf lane's
    child there names its first block, counted in LeafBlocks from the buffer's start (the kernels'
    leaf_block); WideBVH itself is not changed: its lanes keep naming slots."""
    block_size = LEAF_BLOCK_DTYPE.itemsize
    counts = wide.count[wide.count > 0].astype(np.int64)
    total = int((-(-counts // BLOCK_LANES)).sum())
    base = -(-wide.nodes.nbytes // block_size)  # blocks before the first one: the nodes, padded
    buffer = aligned_zeros((base + total) * block_size, np.uint8)  # one allocation, filled in place; Device.adopt's
    _, first_block = leaf_blocks(wide, slots, out=buffer[base * block_size :].view(LEAF_BLOCK_DTYPE))
    nodes = buffer[: wide.nodes.nbytes].view(wide.nodes.dtype)
    nodes[...] = wide.nodes
    nodes["child"][wide.count > 0] = base + first_block
    return buffer
