/* Binned-SAH BVH build (clrender/trace/bvh.py, builder "sah"): one node, or one whole subtree,
 * per work-item.  load_prims makes the primitive records; the host splits the top levels with
 * split_level (one launch per level, one work-item per node), then hands every remaining node to
 * build_subtree, which builds its whole subtree depth-first with an explicit stack;
 * place_subtrees moves each subtree to its depth-first place and prim_order reads the final
 * primitive order.  Each work-item works on its own range of primitives, sequentially, so the
 * tree does not depend on scheduling.
 *
 * Buffers (records declared in clrender/layout.py):
 *   box    -- a BuildPrim per primitive slot (lo, hi; the primitive id in lo.w), permuted in place
 *             as ranges are partitioned
 *   bounds -- a BuildBounds per node: bmin, bmax, and cmin, cmax, the bounds of lo + hi (twice the
 *             centroid: only comparisons and ranges of centroids matter); .w unused
 *   nodes  -- a BvhNode per node (bvh.py's NODE_DTYPE): a leaf's offset is its first slot in box, an
 *             interior node's the index of its far child (its near child follows it)
 *   task   -- a BuildTask per node: first slot, primitives, tree level (root 1), first node of its
 *             subtree in `nodes`
 *   move   -- a SubtreeMove per subtree (place_subtrees)
 *
 * Variants: -DBINS=n bins per axis, -DBUILD_STACK=n pending nodes per work-item (more than the
 * tree's levels).  PoCL calls min/max/fabs out of line, so they are written with ?: here. */

#include "layout.h"

#ifndef BINS
#error "BINS is missing: build through clrender.trace.bvh, which passes the bin count"
#endif
#ifndef BUILD_STACK
#error "BUILD_STACK is missing: build through clrender.trace.bvh, which passes the stack size"
#endif

#define SMALL_BINS (BINS / 2 > 2 ? BINS / 2 : 2) /* bins of nodes of at most 2 * BINS primitives */
#define TRAVERSAL_COST 1.0f /* bvh.py's TRAVERSAL_COST and INTERSECT_COST */
#define INTERSECT_COST 1.0f
#define LARGE_LEAF_SIZE 2 /* primitives a leaf holding a large one may have (BuildRules.large_area) */

/* lane-wise (a vector ?: selects per lane); .w carries no meaning */
inline float4 min4(float4 a, float4 b) { return a < b ? a : b; }

inline float4 max4(float4 a, float4 b) { return a > b ? a : b; }

inline float comp(float4 v, int axis) { return axis == 0 ? v.x : (axis == 1 ? v.y : v.z); }

/* the primitive in a slot: its id, kept in lo's w lane as int32 bits (clrender/layout.py's BuildPrim) */
inline int prim_id(BuildPrim p) { return as_int(p.lo.w); }

/* half the surface area of a box, its sides multiplied by `unit` */
inline float half_area(float4 lo, float4 hi, float unit) {
    float4 e = (hi - lo) * unit;
    float x = e.x > 0.0f ? e.x : 0.0f, y = e.y > 0.0f ? e.y : 0.0f, z = e.z > 0.0f ? e.z : 0.0f;
    return x * y + y * z + z * x;
}

inline void bounds_clear(BuildBounds *b) {
    b->bmin = b->cmin = (float4)(INFINITY, INFINITY, INFINITY, 0.0f);
    b->bmax = b->cmax = (float4)(-INFINITY, -INFINITY, -INFINITY, 0.0f);
}

inline void bounds_add(BuildBounds *b, float4 lo, float4 hi) {
    float4 c = lo + hi;
    b->bmin = min4(b->bmin, lo);
    b->bmax = max4(b->bmax, hi);
    b->cmin = min4(b->cmin, c);
    b->cmax = max4(b->cmax, c);
}

/* The bin of a centroid coordinate; NaN (an infinite centroid times a zero scale) goes to the last
 * bin, the same in the binning and the partition. */
inline int bin_index(float t, int n_bins) { return t < (float)(n_bins - 1) ? (int)t : n_bins - 1; }

inline int bin_of(float c, float cmin, float scale, int n_bins) { return bin_index((c - cmin) * scale, n_bins); }

inline int ceil_log2(int n) {
    int levels = 0;
    while ((1 << levels) < n && levels < 31) levels++;
    return levels;
}

inline void swap_prims(__global BuildPrim *box, int i, int j) {
    BuildPrim p = box[i];
    box[i] = box[j];
    box[j] = p;
}

inline float key_of(__global const BuildPrim *box, int i, int axis) { return comp(box[i].lo + box[i].hi, axis); }

/* Quickselect (Hoare partitions, median-of-three pivot): afterwards slot `nth` holds the
 * primitive of that rank along `axis`, with none greater before it and none smaller after it. */
void select_nth(__global BuildPrim *box, int first, int last, int nth, int axis) {
    while (last > first) {
        float a = key_of(box, first, axis), b = key_of(box, (first + last) / 2, axis), c = key_of(box, last, axis);
        float pivot = a < b ? (b < c ? b : (a < c ? c : a)) : (a < c ? a : (b < c ? c : b));
        int i = first, j = last;
        while (i <= j) {
            while (key_of(box, i, axis) < pivot) i++;
            while (key_of(box, j, axis) > pivot) j--;
            if (i <= j) {
                swap_prims(box, i, j);
                i++;
                j--;
            }
        }
        if (nth <= j)
            last = j;
        else if (nth >= i)
            first = i;
        else
            break;
    }
}

inline void range_bounds(__global const BuildPrim *box, int start, int count, BuildBounds *b) {
    bounds_clear(b);
    for (int i = start; i < start + count; i++) bounds_add(b, box[i].lo, box[i].hi);
}

/* ---- binned SAH: bin the node's centroids along each axis, sweep the cuts between bins, and
 * partition the node's range at the cheapest one */

typedef struct {
    int n_bins;                     /* bins per axis: BINS, or SMALL_BINS for a small node */
    float scale[3];                 /* bins per unit of centroid along each axis; 0: no bins along it */
    int count[3][BINS];             /* primitives per bin */
    float4 lo[3][BINS], hi[3][BINS]; /* their bounds */
} Bins;

typedef struct {
    float cost; /* the SAH cost of the cut, in the sweep's units (see cheapest_cut) */
    int axis;   /* -1: no cut leaves primitives on both sides */
    int bin;    /* bins 0 .. bin go to the first child */
} Cut;

INLINE void bins_clear(Bins *bins, int count, const BuildBounds *node) {
    /* small nodes use half the bins: their bin tables would outweigh their primitives */
    int n_bins = count <= 2 * BINS ? SMALL_BINS : BINS;
    float4 extent = node->cmax - node->cmin;
    bins->n_bins = n_bins;
    for (int a = 0; a < 3; a++) {
        float e = comp(extent, a);
        float s = e > 0.0f ? (float)n_bins / e : 0.0f;
        bins->scale[a] = s <= FLT_MAX ? s : 0.0f; /* a tiny extent: no bins along this axis */
    }
    for (int a = 0; a < 3; a++)
        for (int b = 0; b < n_bins; b++) {
            bins->count[a][b] = 0;
            bins->lo[a][b] = (float4)(INFINITY, INFINITY, INFINITY, 0.0f);
            bins->hi[a][b] = (float4)(-INFINITY, -INFINITY, -INFINITY, 0.0f);
        }
}

INLINE void bin_add(Bins *bins, int axis, int b, float4 lo, float4 hi) {
    bins->count[axis][b]++;
    bins->lo[axis][b] = min4(bins->lo[axis][b], lo);
    bins->hi[axis][b] = max4(bins->hi[axis][b], hi);
}

/* every primitive of [start, start + count) when take == count, else an evenly strided sample of `take` */
INLINE void bins_fill(Bins *bins, __global const BuildPrim *box, int start, int count, int take, const BuildBounds *node) {
    int n_bins = bins->n_bins;
    float sx = bins->scale[0], sy = bins->scale[1], sz = bins->scale[2];
    for (int j = 0; j < take; j++) {
        int i = start + (take == count ? j : (int)(((long)j * count) / take));
        float4 lo = box[i].lo, hi = box[i].hi;
        float4 c = lo + hi;
        int bx = bin_of(c.x, node->cmin.x, sx, n_bins);
        int by = bin_of(c.y, node->cmin.y, sy, n_bins);
        int bz = bin_of(c.z, node->cmin.z, sz, n_bins);
        bin_add(bins, 0, bx, lo, hi);
        bin_add(bins, 1, by, lo, hi);
        bin_add(bins, 2, bz, lo, hi);
    }
}

/* Lengths in units of the node's longest side, so that areas neither overflow nor underflow in very
 * large or very small scenes (the cost compares ratios of areas only). */
INLINE float area_unit(const BuildBounds *node) {
    float4 side = node->bmax - node->bmin;
    float longest = side.x > side.y ? (side.x > side.z ? side.x : side.z) : (side.y > side.z ? side.y : side.z);
    float unit = longest > 0.0f ? 1.0f / longest : 1.0f;
    return unit <= FLT_MAX && unit > 0.0f ? unit : 1.0f; /* a denormal or infinite side: as is */
}

/* The sweep: cost of cut b (bins 0..b left) = area(left) * n_left + area(right) * n_right; ties go to
 * the lower axis, then the lower cut. */
INLINE Cut cheapest_cut(const Bins *bins, float unit) {
    int n_bins = bins->n_bins;
    Cut best = {INFINITY, -1, 0};
    for (int a = 0; a < 3; a++) {
        float area_right[BINS];
        int n_right[BINS];
        float4 lo = (float4)(INFINITY, INFINITY, INFINITY, 0.0f), hi = -lo;
        int n = 0;
        for (int b = n_bins - 1; b > 0; b--) {
            n += bins->count[a][b];
            lo = min4(lo, bins->lo[a][b]);
            hi = max4(hi, bins->hi[a][b]);
            area_right[b - 1] = half_area(lo, hi, unit);
            n_right[b - 1] = n;
        }
        lo = (float4)(INFINITY, INFINITY, INFINITY, 0.0f);
        hi = -lo;
        n = 0;
        for (int b = 0; b < n_bins - 1; b++) {
            n += bins->count[a][b];
            lo = min4(lo, bins->lo[a][b]);
            hi = max4(hi, bins->hi[a][b]);
            if (n == 0 || n_right[b] == 0) continue;
            float cost = half_area(lo, hi, unit) * (float)n + area_right[b] * (float)n_right[b];
            if (cost < best.cost) {
                best.cost = cost;
                best.axis = a;
                best.bin = b;
            }
        }
    }
    return best;
}

/* Whether a node of `count` primitives (`take` of them binned) is better left a leaf than cut. */
INLINE bool leaf_is_cheaper(const BuildBounds *node, Cut cut, int count, int take, float unit, BuildRules p) {
    float node_area = half_area(node->bmin, node->bmax, unit);
    node_area = node_area > 0.0f ? node_area : 1.0f;
    float cost = TRAVERSAL_COST + INTERSECT_COST * ((float)count / (float)take) * cut.cost / node_area;
    return cost >= INTERSECT_COST * (float)count && count <= p.leaf_cap;
}

/* Primitives whose bin along the cut's axis is <= cut.bin first (two fingers, each primitive read
 * once), the children's bounds on the way; returns the first child's primitives. */
INLINE int partition_at(__global BuildPrim *box, int start, int count, const BuildBounds *node, const Bins *bins, Cut cut,
                        BuildBounds *left, BuildBounds *right) {
    float cmin = comp(node->cmin, cut.axis), s = bins->scale[cut.axis];
    int n_bins = bins->n_bins;
    bounds_clear(left);
    bounds_clear(right);
    int i = start, j = start + count - 1;
    while (i <= j) {
        BuildPrim prim = box[i];
        if (bin_of(comp(prim.lo + prim.hi, cut.axis), cmin, s, n_bins) <= cut.bin) {
            bounds_add(left, prim.lo, prim.hi);
            i++;
        } else {
            bounds_add(right, prim.lo, prim.hi);
            box[i] = box[j];
            box[j] = prim;
            j--;
        }
    }
    return i - start;
}

/* Halves along the widest centroid axis: the first child gets count / 2 primitives. */
INLINE int split_in_halves(__global BuildPrim *box, int start, int count, const BuildBounds *node, BuildBounds *left,
                           BuildBounds *right) {
    float4 extent = node->cmax - node->cmin;
    int axis = extent.x >= extent.y ? (extent.x >= extent.z ? 0 : 2) : (extent.y >= extent.z ? 1 : 2);
    int n_first = count / 2;
    if (comp(extent, axis) > 0.0f) select_nth(box, start, start + count - 1, start + n_first, axis);
    range_bounds(box, start, n_first, left);
    range_bounds(box, start + n_first, count - n_first, right);
    return n_first;
}

/* Whether a node of `count` primitives, a leaf by its count, holds a large one (a wall, a floor) and more than one other:
 * a leaf's box is tested by every ray that meets any of its primitives, so a large primitive kept with small ones
 * makes their triangle tests every ray's. */
INLINE bool holds_large(__global const BuildPrim *box, int start, int count, BuildRules p) {
    if (count <= LARGE_LEAF_SIZE) return false;
    for (int i = start; i < start + count; ++i)
        if (half_area(box[i].lo, box[i].hi, p.root_unit) >= p.large_area) return true;
    return false;
}

/* How the node of primitives [start, start + count) at tree level `depth` splits: returns the
 * number of primitives of its first child, moved to the front of the range, with both
 * children's bounds; 0 for a leaf (at most max_leaf primitives, unless holds_large).  By the best
 * binned-SAH cut over the three axes, else (a small node, one too deep to finish by SAH within
 * max_levels, or one whose centroids all fall into one bin) in halves along the axis of widest
 * centroid extent. */
int split_node(__global BuildPrim *box, int start, int count, int depth, const BuildBounds *node, BuildRules p,
               BuildBounds *left, BuildBounds *right) {
    bool split_large = count <= p.max_leaf && holds_large(box, start, count, p);
    if (count <= p.max_leaf && !split_large) return 0;
    bool halve = count <= p.halving_below || depth + ceil_log2(count) + 1 >= p.max_levels;
    if (!halve) {
        Bins bins;
        bins_clear(&bins, count, node);
        /* all primitives of a small node, an evenly strided sample of a big one */
        int take = count > p.samples ? p.samples : count;
        bins_fill(&bins, box, start, count, take, node);
        float unit = area_unit(node);
        Cut cut = cheapest_cut(&bins, unit);
        if (cut.axis >= 0) {
            if (!split_large && leaf_is_cheaper(node, cut, count, take, unit, p)) return 0;
            return partition_at(box, start, count, node, &bins, cut, left, right);
        }
    }
    return split_in_halves(box, start, count, node, left, right);
}

/* A node's box, then its offset and count (see the buffers above). */
inline void write_node(__global BvhNode *node, const BuildBounds *b, int offset, int count) {
    vstore3(b->bmin.xyz, 0, node->bmin);
    node->offset = offset;
    vstore3(b->bmax.xyz, 0, node->bmax);
    node->count = count;
}

/* One top-level node per work-item: split it, write how (first child's primitives, 0 for a leaf)
 * and the children's bounds (left_bounds[t], right_bounds[t]). */
__kernel void split_level(__global BuildPrim *box, __global const BuildTask *task, __global const BuildBounds *bounds,
                          int n_tasks, BuildRules rules, __global int *n_first, __global BuildBounds *left_bounds,
                          __global BuildBounds *right_bounds) {
    int t = get_global_id(0);
    if (t >= n_tasks) return;
    BuildTask k = task[t];
    BuildBounds node = bounds[t], left, right;
    int n = split_node(box, k.first, k.count, k.level, &node, rules, &left, &right);
    n_first[t] = n;
    if (n > 0) {
        left_bounds[t] = left;
        right_bounds[t] = right;
    }
}

typedef struct {
    BuildBounds b;
    int start, count, depth, parent; /* parent: the node whose far child this is, -1 for a near child */
} Pending;

/* One subtree per work-item, written depth-first from node task.first_node on (at most 2 * count - 1
 * nodes); writes its node count to n_nodes[t].  Far-child offsets are absolute indices in `nodes`. */
__kernel void build_subtree(__global BuildPrim *box, __global const BuildTask *task, __global const BuildBounds *bounds,
                            int n_tasks, BuildRules rules, __global BvhNode *nodes, __global int *n_nodes) {
    int t = get_global_id(0);
    if (t >= n_tasks) return;
    BuildTask k = task[t];
    Pending stack[BUILD_STACK];
    stack[0].b = bounds[t];
    stack[0].start = k.first;
    stack[0].count = k.count;
    stack[0].depth = k.level;
    stack[0].parent = -1;
    int sp = 1, next = k.first_node;
    while (sp > 0) {
        Pending e = stack[--sp];
        int i = next++;
        if (e.parent >= 0) nodes[e.parent].offset = i; /* the far child is here */
        BuildBounds left, right;
        int n = sp + 2 <= BUILD_STACK ? split_node(box, e.start, e.count, e.depth, &e.b, rules, &left, &right) : 0;
        if (n == 0) {
            write_node(nodes + i, &e.b, e.start, e.count);
            continue;
        }
        write_node(nodes + i, &e.b, 0, 0);
        /* put the far child on the stack, then the near one, popped next (it is node i + 1) */
        stack[sp].b = right;
        stack[sp].start = e.start + n;
        stack[sp].count = e.count - n;
        stack[sp].depth = e.depth + 1;
        stack[sp].parent = i;
        stack[sp + 1].b = left;
        stack[sp + 1].start = e.start;
        stack[sp + 1].count = n;
        stack[sp + 1].depth = e.depth + 1;
        stack[sp + 1].parent = -1;
        sp += 2;
    }
    n_nodes[t] = next - k.first_node;
}

/* Primitive records from the bounds arrays (n rows of 3 floats each), a chunk of primitives per
 * work-item, and each chunk's bounds (the host merges them into the root's). */
__kernel void load_prims(__global const float *lo, __global const float *hi, int n, int chunk, __global BuildPrim *box,
                         __global BuildBounds *chunk_bounds) {
    int g = get_global_id(0);
    int first = g * chunk, last = first + chunk < n ? first + chunk : n;
    BuildBounds b;
    bounds_clear(&b);
    for (int i = first; i < last; i++) {
        BuildPrim prim = {(float4)(vload3(i, lo), as_float(i)), (float4)(vload3(i, hi), 0.0f)};
        box[i] = prim;
        bounds_add(&b, prim.lo, prim.hi);
    }
    chunk_bounds[g] = b;
}

/* The primitive id of every slot, a chunk per work-item. */
__kernel void prim_order(__global const BuildPrim *box, int n, int chunk, __global int *order) {
    int g = get_global_id(0);
    int first = g * chunk, last = first + chunk < n ? first + chunk : n;
    for (int i = first; i < last; i++) order[i] = prim_id(box[i]);
}

/* Each subtree's nodes from where build_subtree wrote them to their depth-first place, interior
 * nodes' far-child offsets moved along; a subtree per work-item. */
__kernel void place_subtrees(__global const BvhNode *scratch, __global const SubtreeMove *move, int n_moves,
                             __global BvhNode *nodes) {
    int t = get_global_id(0);
    if (t >= n_moves) return;
    SubtreeMove m = move[t];
    for (int k = 0; k < m.nodes; k++) {
        BvhNode node = scratch[m.source + k];
        if (node.count == 0) node.offset += m.target - m.source; /* interior: the far child moves along */
        nodes[m.target + k] = node;
    }
}
