/* Ray-primitive tests and BVH traversal (closest hit and shadow transmittance). */
#ifndef CLRENDER_INTERSECT_H
#define CLRENDER_INTERSECT_H

#include "common.h"

/* No contraction of a*b + c into fma here: the one-triangle and the block tests must round alike. */
#pragma OPENCL FP_CONTRACT OFF

typedef struct {
    float t;       /* distance along the (unit) direction; INF_T on a miss */
    int slot;      /* index into prims; -1 on a miss */
    int id;        /* primitive id in scene order; -1 on a miss */
    float u, v;    /* barycentrics of v1 and v2 on a triangle */
} Hit;

/* The scene's geometry as every traversal reads it (packed by clrender/trace/tracer.py). */
typedef struct {
    __global const float4 *nodes;      /* the BVH: binary nodes, or wide nodes and leaf blocks (clrender/trace/bvh*.py) */
    __global const float4 *prims;      /* primitive slots, in the tree's leaf order */
    __global const int *prim_object;   /* object id of each primitive id */
    __global const ObjectRecord *objects;
    __global const Material *materials;
    int n_prims;
} Geometry;

INLINE Geometry geometry(__global const float4 *nodes, __global const float4 *prims, __global const int *prim_object,
                         __global const ObjectRecord *objects, __global const Material *materials, int n_prims) {
    Geometry g;
    g.nodes = nodes; g.prims = prims; g.prim_object = prim_object; g.objects = objects; g.materials = materials;
    g.n_prims = n_prims;
    return g;
}

/* What a shadow ray keeps crossing primitive `id` (its material's transparency). */
INLINE float transparency_of(const Geometry *g, int id) { return g->materials[g->objects[g->prim_object[id]].material].transparency; }

INLINE Hit no_hit(void) {
    Hit h;
    h.t = INF_T; h.slot = -1; h.id = -1; h.u = 0.0f; h.v = 0.0f;
    return h;
}

/* A primitive slot (layout.PRIM_SLOT_DTYPE): its second row ends in 1 for a sphere, 0 for a triangle;
 * its first row ends in the primitive's id, as int bits. */
INLINE bool is_sphere_row(float4 second_row) { return second_row.w != 0.0f; }

INLINE bool is_sphere(__global const float4 *prims, int slot) { return is_sphere_row(prims[PRIM_ROWS * slot + 1]); }

INLINE int prim_id(__global const float4 *prims, int slot) { return as_int(prims[PRIM_ROWS * slot].w); }

#define GAMMA(n) ((float)(n) * 5.96046448e-8f / (1.0f - (float)(n) * 5.96046448e-8f)) /* n*u/(1-n*u), u = 2^-24 */

/* The triangle test, once per lane type (kernels/triangle.h, which undefines the TRI_ names after use) */
#define TRI_F float
#define TRI_I int
#define TRI_ANY(m) (m)
#define TRI_ABS abs_f
#define TRI_DOP difference_of_products
#define TRI_TEST triangle_test
#define TRI_R float
#include "triangle.h"
#define TRI_F float4
#define TRI_I int4
#define TRI_ANY(m) (((m).x | (m).y | (m).z | (m).w) != 0)
#define TRI_ABS abs4
#define TRI_DOP difference_of_products4
#define TRI_TEST triangle_test4
#define TRI_R float
#include "triangle.h"

/* One triangle (the records' vertices v0, v1, v2): t in (t_min, t_max) or INF_T, and u, v. */
INLINE float hit_triangle(Ray r, float4 v0, float4 v1, float4 v2, float t_min, float t_max, float *u, float *v) {
    float3 q0 = v0.xyz - r.o, q1 = v1.xyz - r.o, q2 = v2.xyz - r.o;
    return triangle_test(axis_of(q0, r.kx), axis_of(q0, r.ky), axis_of(q0, r.kz), axis_of(q1, r.kx),
                         axis_of(q1, r.ky), axis_of(q1, r.kz), axis_of(q2, r.kx), axis_of(q2, r.ky),
                         axis_of(q2, r.kz), 1, r.sx, r.sy, r.sz, t_min, t_max, u, v);
}

/* The triangles of a leaf block (layout.py BLOCK_*: rows 3v + axis hold vertex v's coordinates of
 * every lane), in lanes where `valid` is set: the same operations as hit_triangle, lane by lane. */
INLINE float4 hit_block(Ray r, __global const float4 *block, int4 valid, float t_min, float t_max, float4 *u,
                        float4 *v) {
    float ox = axis_of(r.o, r.kx), oy = axis_of(r.o, r.ky), oz = axis_of(r.o, r.kz);
    return triangle_test4(block[r.kx] - ox, block[r.ky] - oy, block[r.kz] - oz, block[3 + r.kx] - ox,
                          block[3 + r.ky] - oy, block[3 + r.kz] - oz, block[6 + r.kx] - ox, block[6 + r.ky] - oy,
                          block[6 + r.kz] - oz, valid, r.sx, r.sy, r.sz, t_min, t_max, u, v);
}

/* Both roots of |o + t d - c|^2 = r^2 for unit d, in the cancellation-free
 * form (Ray Tracing Gems ch. 7): the discriminant from the ray's closest
 * approach, the small root from c/q. */
INLINE int sphere_roots(Ray r, float4 cr, float *t0, float *t1) {
    float3 oc = r.o - cr.xyz;
    float b = dot3(oc, r.d);
    float3 closest = oc - b * r.d;
    float radius = cr.w;
    float closest_dist = sqrt(dot3(closest, closest));
    float disc = (radius - closest_dist) * (radius + closest_dist);
    if (disc < 0.0f) return 0;
    float c = dot3(oc, oc) - radius * radius;
    float q = -b - copysign(sqrt(disc), b);
    float a0 = (q != 0.0f) ? c / q : 0.0f, a1 = q;
    *t0 = min_f(a0, a1);
    *t1 = max_f(a0, a1);
    return 1;
}

/* Roots closer than this are within the rounding error of sphere_roots (a few
 * ulps of |o - c| and the radius; o and c are exact floats, so o - c errs
 * relative to itself) and are not hits: a ray leaving the sphere's own
 * surface, offset by offset_origin, must not find it again. */
INLINE float sphere_t_eps(Ray r, float4 cr) {
    float3 oc = abs3(r.o - cr.xyz);
    return GAMMA(8) * (oc.x + oc.y + oc.z + cr.w);
}

INLINE float hit_sphere(Ray r, float4 cr, float t_min, float t_max) {
    float t0, t1;
    if (!sphere_roots(r, cr, &t0, &t1)) return INF_T;
    t_min = max_f(t_min, sphere_t_eps(r, cr));
    if (t0 > t_min && t0 < t_max) return t0;
    if (t1 > t_min && t1 < t_max) return t1;
    return INF_T;
}

/* The hit point on a triangle from its barycentrics (not o + t d, whose error
 * grows with t), and a bound on its float32 error per axis (pbrt-v4). */
INLINE float3 hit_point_triangle(float4 v0, float4 v1, float4 v2, float u, float v, float3 *p_err) {
    float b0 = 1.0f - u - v;
    float3 a0 = b0 * v0.xyz, a1 = u * v1.xyz, a2 = v * v2.xyz;
    *p_err = GAMMA(7) * (abs3(a0) + abs3(a1) + abs3(a2));
    return a0 + a1 + a2;
}

/* The hit point on a sphere, moved onto the surface along the radius
 * (pbrt-v4's reprojection), and a bound on its float32 error per axis. */
INLINE float3 hit_point_sphere(float4 centre_radius, float3 p_ray, float3 *p_err) {
    float3 rel = p_ray - centre_radius.xyz;
    rel *= centre_radius.w / norm(rel);
    float3 p = centre_radius.xyz + rel;
    *p_err = GAMMA(5) * abs3(rel) + GAMMA(2) * abs3(p);
    return p;
}

/* Distance to primitive slot s in (t_min, t_max), or INF_T; u, v set on a triangle hit. */
INLINE float hit_slot(__global const float4 *prims, int s, Ray r, float t_min, float t_max, float *u, float *v) {
    float4 a = prims[PRIM_ROWS * s], b = prims[PRIM_ROWS * s + 1], c = prims[PRIM_ROWS * s + 2];
    if (is_sphere_row(b)) return hit_sphere(r, (float4)(a.xyz, b.x), t_min, t_max);
    return hit_triangle(r, a, b, c, t_min, t_max, u, v);
}

/* One slab of the box test: the entry and exit distances (lo - o) / d and
 * (hi - o) / d, picked by the sign of 1/d (so -0 counts as negative).  The
 * form (b - o) * inv_d is inf, never inf - inf, when d is zero and o lies off
 * the slab's planes; it is NaN only when 0 * inf, i.e. d is zero and o lies
 * exactly on a plane: the ray runs inside the closed slab, and the caller's
 * max_f/min_f chains drop a NaN, so that axis then bounds nothing. */
INLINE void slab(float lo, float hi, float o, float inv_d, float *t_enter, float *t_exit) {
    float t_lo = (lo - o) * inv_d, t_hi = (hi - o) * inv_d;
    bool backwards = inv_d < 0.0f;
    float near = backwards ? t_hi : t_lo, far = backwards ? t_lo : t_hi;
    *t_enter = max_f(near, *t_enter); /* a NaN `near` keeps t_enter */
    *t_exit = min_f(far, *t_exit);    /* a NaN `far` keeps t_exit */
}

/* Slab test; returns the entry distance or INF_T.  Correct for every
 * direction, zero and negative-zero components included, and conservative:
 * the exit distance is widened by 1 + 2*gamma(3) (pbrt-v4) so rounding never
 * culls a box a hit lies in.  Scalars: float3 arithmetic costs shuffles on CPUs. */
INLINE float hit_box(Ray r, float4 bmin, float4 bmax, float t_max) {
    float t_enter = 0.0f, t_exit = t_max;
    slab(bmin.x, bmax.x, r.o.x, r.inv_d.x, &t_enter, &t_exit);
    slab(bmin.y, bmax.y, r.o.y, r.inv_d.y, &t_enter, &t_exit);
    slab(bmin.z, bmax.z, r.o.z, r.inv_d.z, &t_enter, &t_exit);
    t_exit *= 1.0000004f;
    return t_enter <= t_exit ? t_enter : INF_T;
}

/* Test slots [begin, end), keeping the nearest hit.  Ties go to the lower
 * primitive id, so every traversal order (BVH on or off, either builder)
 * finds the same primitive. */
INLINE void test_slots(__global const float4 *prims, int begin, int end, Ray r, float t_min, Hit *best) {
    for (int s = begin; s < end; ++s) {
        float u = 0.0f, v = 0.0f;
        float t = hit_slot(prims, s, r, t_min, best->t * 1.0000002f, &u, &v);
        int id = prim_id(prims, s);
        if (t < best->t || (t == best->t && t != INF_T && id < best->id)) {
            best->t = t; best->slot = s; best->id = id; best->u = u; best->v = v;
        }
    }
}

/* ---------------------------------------------------------------- wide BVH (clrender/trace/bvh_wide.py)
 * BVH_WIDTH 4 or 8.  A node is 8 rows of BVH_WIDTH floats (float4 or float8 rows, read as typed
 * vectors: vloadN here was 17% slower on PoCL): lo_x, hi_x, lo_y, hi_y, lo_z, hi_z of its
 * children, then the children's int32 index (wide node, or the row of a leaf's first block) and
 * count (0 interior, > 0 leaf primitives, -1 empty lane).  The slab test is hit_box's, lane by
 * lane: the same float operations, so each lane's answer is bit for bit the binary test's for that
 * box.  Stack entries are lane keys (lane_keys) with their node; see Walk. */
#if BVH_WIDTH >= 4
#if BVH_WIDTH == 4
typedef float4 lanes_f;
#define as_lanes_f as_float4
typedef int4 lanes_i;
#define as_lanes_i as_int4
typedef uint4 lanes_u;
#define as_lanes_u as_uint4
#define LANE_IDS ((lanes_u)(0, 1, 2, 3))
#define LANES_ARRAY(v) {(v).s0, (v).s1, (v).s2, (v).s3}
#else
typedef float8 lanes_f;
#define as_lanes_f as_float8
typedef int8 lanes_i;
#define as_lanes_i as_int8
typedef uint8 lanes_u;
#define as_lanes_u as_uint8
#define LANE_IDS ((lanes_u)(0, 1, 2, 3, 4, 5, 6, 7))
#define LANES_ARRAY(v) {(v).s0, (v).s1, (v).s2, (v).s3, (v).s4, (v).s5, (v).s6, (v).s7}
#endif
#define LANE_MASK ((uint)(BVH_WIDTH - 1))

/* How many lanes of a comparison result (-1 true, 0 false) are set.  Summed pairwise in vectors:
 * Oclgrind evaluates the flat sum s0 + s1 + ... + s7 of such lanes wrongly (255 per lane, once
 * LLVM has turned it into a sum of i1 masks). */
INLINE int hit_count(lanes_i h) {
#if BVH_WIDTH == 8
    int4 s4 = h.lo + h.hi;
#else
    int4 s4 = h;
#endif
    int2 s2 = s4.lo + s4.hi;
    return -(s2.x + s2.y);
}
#define NODE_FLOATS (WIDE_NODE_ROWS * BVH_WIDTH) /* rows of BVH_WIDTH lanes (clrender/layout.py) */
#define CHILD_ROW (WIDE_CHILD_ROW * BVH_WIDTH)
#define COUNT_ROW (WIDE_COUNT_ROW * BVH_WIDTH)

/* One axis of the box test for every lane: the near plane's row is `near` (lo, or hi for a ray
 * going backwards along the axis: the rows are picked by index, not by selecting results), the far
 * plane's the other.  A NaN lane of the entry distance (0 * inf: the ray runs in a box plane) keeps
 * t_enter, as max_f does; ?: rather than select(), which PoCL calls out of line. */
INLINE void slab_lanes(lanes_f near_plane, lanes_f far_plane, float o, float inv_d, lanes_f *t_enter,
                       lanes_f *t_exit) {
    lanes_f near = (near_plane - o) * inv_d, far = (far_plane - o) * inv_d;
    *t_enter = near > *t_enter ? near : *t_enter;
    *t_exit = far < *t_exit ? far : *t_exit;
}

/* Entry distances of the lanes of a node (INF_T where the box is missed or the lane is empty).
 * Rows 2a and 2a + 1 hold lo and hi along axis a; the sign of 1/d picks which is near. */
INLINE lanes_f hit_boxes(Ray r, __global const lanes_f *node, float t_max) {
    int bx = r.inv_d.x < 0.0f, by = r.inv_d.y < 0.0f, bz = r.inv_d.z < 0.0f; /* -0 counts as backwards */
    lanes_f t_enter = (lanes_f)(0.0f), t_exit = (lanes_f)(t_max);
    slab_lanes(node[bx], node[1 - bx], r.o.x, r.inv_d.x, &t_enter, &t_exit);
    slab_lanes(node[2 + by], node[3 - by], r.o.y, r.inv_d.y, &t_enter, &t_exit);
    slab_lanes(node[4 + bz], node[5 - bz], r.o.z, r.inv_d.z, &t_enter, &t_exit);
    t_exit *= 1.0000004f;
    /* empty lanes hold the box [+inf, -inf], missed by every ray (bvh_wide.py) */
    return t_enter <= t_exit ? t_enter : (lanes_f)(INF_T);
}

/* Stack keys: a hit lane's entry distance with its lane number in the low log2(BVH_WIDTH) bits (the
 * distance rounded down there, so a key's distance never exceeds the box's: culling by it stays
 * conservative), plus one, so that 0 means "missed".  Non-negative floats order as their bits, so
 * the keys order as the distances.  `farthest_first` inverts the order (any-hit queries). */
INLINE lanes_u lane_keys(lanes_f t, bool farthest_first) {
    lanes_u key = (as_lanes_u(t) & ~(lanes_u)(LANE_MASK)) | LANE_IDS;
    key = farthest_first ? ~key : key + 1u;
    return t != (lanes_f)(INF_T) ? key : (lanes_u)(0u);
}
INLINE uint key_lane(uint key, bool farthest_first) { return (farthest_first ? ~key : key - 1u) & LANE_MASK; }
INLINE float key_t(uint key) { return as_float((key - 1u) & ~LANE_MASK); }

/* One step of a bitonic sorting network: each lane against lane ^ j, keeping the larger where
 * `keep_max` is set.  Swizzles and ?: only: no branches, no library calls. */
#define SORT_STEP(v, partner, keep_max) { lanes_u p_ = (partner); \
    lanes_u hi_ = (v) > p_ ? (v) : p_, lo_ = (v) > p_ ? p_ : (v); (v) = (keep_max) ? hi_ : lo_; }

/* The keys in decreasing order (missed lanes, key 0, last). */
INLINE lanes_u sort_keys_decreasing(lanes_u v) {
#if BVH_WIDTH == 4
    SORT_STEP(v, v.s1032, (lanes_i)(-1, 0, 0, -1));
    SORT_STEP(v, v.s2301, (lanes_i)(-1, -1, 0, 0));
    SORT_STEP(v, v.s1032, (lanes_i)(-1, 0, -1, 0));
#else
    SORT_STEP(v, v.s10325476, (lanes_i)(-1, 0, 0, -1, -1, 0, 0, -1));
    SORT_STEP(v, v.s23016745, (lanes_i)(-1, -1, 0, 0, 0, 0, -1, -1));
    SORT_STEP(v, v.s10325476, (lanes_i)(-1, 0, -1, 0, 0, -1, 0, -1));
    SORT_STEP(v, v.s45670123, (lanes_i)(-1, -1, -1, -1, 0, 0, 0, 0));
    SORT_STEP(v, v.s23016745, (lanes_i)(-1, -1, 0, 0, -1, -1, 0, 0));
    SORT_STEP(v, v.s10325476, (lanes_i)(-1, 0, -1, 0, -1, 0, -1, 0));
#endif
    return v;
}

/* Push the hit lanes of `node`: their keys sorted so that the top of the stack is the nearest
 * (closest hit) or the farthest (any-hit: the boxes nearest a shadow ray's origin rarely block
 * it).  All BVH_WIDTH keys are written (the arrays have that much slack), the stack grows by
 * the number of hits.  No branch per lane: which lanes hit is unpredictable. */
/* The largest key of a node (its only hit lane's, when one lane hit). */
INLINE uint max_key(lanes_u k) {
#if BVH_WIDTH == 8
    uint4 m4 = k.lo > k.hi ? k.lo : k.hi;
#else
    uint4 m4 = k;
#endif
    uint2 m2 = m4.lo > m4.hi ? m4.lo : m4.hi;
    return m2.x > m2.y ? m2.x : m2.y;
}

INLINE int push_lanes(int node, lanes_f t_lanes, bool farthest_first, uint *stack_key, int *stack_node, int sp,
                      bool *overflow) {
    lanes_u keys = lane_keys(t_lanes, farthest_first);
    lanes_i hit = keys != (lanes_u)(0u);
    int n = hit_count(hit);
    if (n == 0) return sp;
    if (sp + n > WIDE_STACK_SIZE) { *overflow = true; return sp; }
    if (n == 1) { /* one hit lane, the common case: no sort */
        stack_key[sp] = max_key(keys); stack_node[sp] = node;
        return sp + 1;
    }
    keys = sort_keys_decreasing(keys);
    uint k[BVH_WIDTH] = LANES_ARRAY(keys);
    for (int j = 0; j < BVH_WIDTH; ++j) { stack_key[sp + j] = k[j]; stack_node[sp + j] = node; }
    return sp + n;
}

/* The blocks of a leaf of `count` primitives whose first block starts at row `first` of the wide
 * tree's rows (bvh_wide.kernel_rows), keeping the nearest hit as test_slots does: the same t, and
 * ties to the lower primitive id.  Sphere lanes (rare: a sphere is one primitive) go one by one. */
INLINE void test_blocks(__global const float4 *rows, int first, int count, __global const float4 *prims, Ray r,
                        float t_min, Hit *best) {
    for (int b = 0; b < count; b += BLOCK_LANES, first += BLOCK_ROWS) {
        __global const float4 *block = rows + first;
        int4 slot = as_int4(block[BLOCK_SLOT_ROW]);
        float4 u, v;
        float4 t = hit_block(r, block, slot >= 0, t_min, best->t * 1.0000002f, &u, &v);
        float2 m2 = t.lo < t.hi ? t.lo : t.hi;
        if (min_f(m2.x, m2.y) <= best->t) { /* some lane hit: the nearest, ties to the lower id */
            float tl[4] = {t.x, t.y, t.z, t.w}, ul[4] = {u.x, u.y, u.z, u.w}, vl[4] = {v.x, v.y, v.z, v.w};
            int sl[4] = {slot.x, slot.y, slot.z, slot.w};
            for (int k = 0; k < BLOCK_LANES; ++k) {
                if (tl[k] == INF_T) continue;
                int id = prim_id(prims, sl[k]);
                if (tl[k] < best->t || (tl[k] == best->t && id < best->id)) {
                    best->t = tl[k]; best->slot = sl[k]; best->id = id; best->u = ul[k]; best->v = vl[k];
                }
            }
        }
        if (slot.x < -1 || slot.y < -1 || slot.z < -1 || slot.w < -1) { /* spheres: -2 - slot */
            int sl[4] = {slot.x, slot.y, slot.z, slot.w};
            for (int k = 0; k < BLOCK_LANES; ++k)
                if (sl[k] < -1) test_slots(prims, -2 - sl[k], -1 - sl[k], r, t_min, best);
        }
    }
}

#endif


/* Fraction of light reaching t_max along the ray: 0 past an opaque surface,
 * times `transparency` for every crossing of a transparent one (the shadow
 * ray is not bent).  Stops as soon as an opaque surface is found.  With
 * opaque_only every surface blocks (a plain any-hit occlusion query). */
INLINE float crossing_transmittance(const Geometry *g, int s, Ray r, float t_min, float t_max, bool opaque_only) {
    __global const float4 *prims = g->prims;
    float4 a = prims[PRIM_ROWS * s], b = prims[PRIM_ROWS * s + 1], c = prims[PRIM_ROWS * s + 2];
    int crossings = 0;
    if (is_sphere_row(b)) {
        float t0, t1;
        float4 cr = (float4)(a.xyz, b.x);
        if (sphere_roots(r, cr, &t0, &t1)) {
            float t_lo = max_f(t_min, sphere_t_eps(r, cr));
            crossings = (t0 > t_lo && t0 < t_max) + (t1 > t_lo && t1 < t_max);
        }
    } else {
        float u, v;
        crossings = hit_triangle(r, a, b, c, t_min, t_max, &u, &v) != INF_T;
    }
    if (crossings == 0) return 1.0f;
    if (opaque_only) return 0.0f;
    float transparency = transparency_of(g, as_int(a.w));
    return crossings == 2 ? transparency * transparency : transparency;
}

#if BVH_WIDTH >= 4
/* Transmittance through the blocks of one leaf (see test_blocks): crossing_transmittance of each
 * primitive, the triangles of a block tested at once. */
INLINE float blocks_transmittance(const Geometry *g, int first, int count, Ray r, float t_min, float t_max,
                                  bool opaque_only) {
    __global const float4 *rows = g->nodes;
    float T = 1.0f;
    for (int b = 0; b < count && T > 0.0f; b += BLOCK_LANES, first += BLOCK_ROWS) {
        __global const float4 *block = rows + first;
        int4 slot = as_int4(block[BLOCK_SLOT_ROW]);
        float4 u, v;
        int4 crossed = hit_block(r, block, slot >= 0, t_min, t_max, &u, &v) != (float4)(INF_T);
        int cl[4] = {crossed.x, crossed.y, crossed.z, crossed.w}, sl[4] = {slot.x, slot.y, slot.z, slot.w};
        if (crossed.x | crossed.y | crossed.z | crossed.w) {
            if (opaque_only) return 0.0f;
            for (int k = 0; k < BLOCK_LANES; ++k) /* a triangle is crossed once: times its transparency */
                if (cl[k]) T *= transparency_of(g, prim_id(g->prims, sl[k]));
        }
        if (slot.x < -1 || slot.y < -1 || slot.z < -1 || slot.w < -1) /* spheres: -2 - slot */
            for (int k = 0; k < BLOCK_LANES && T > 0.0f; ++k)
                if (sl[k] < -1)
                    T *= crossing_transmittance(g, -2 - sl[k], r, t_min, t_max, opaque_only);
    }
    return T;
}

/* A ray's walk through the wide tree, as a state a work-item can advance one stack entry at a time:
 * the ray kernels step two rays in turn, whose steps do not depend on each other, so the CPU overlaps
 * one's memory and branch latencies with the other's work (+10-15% per ray measured).  Closest hit:
 * `best` shrinks the search as hits are found; any-hit (shadow rays): `T` is the light getting
 * through so far, and the walk ends at an opaque hit.  Stack entries are lane keys (lane_keys) with
 * the node they belong to; trees are at most clrender.trace.bvh.MAX_TREE_LEVELS deep, so the stack
 * holds at most BVH_WIDTH - 1 siblings per level plus one node's lanes
 * (clrender.trace.knobs.TraceKnobs.wide_stack_size); should it fill up, every primitive is tested at the end. */
typedef struct {
    Ray r;
    float t_min, t_max; /* any-hit: the segment; closest hit: t_max is the nearest hit so far */
    Hit best;
    float T;
    int sp;
    bool overflow;
    uint visits;
    uint stack_key[WIDE_STACK_SIZE + BVH_WIDTH];
    int stack_node[WIDE_STACK_SIZE + BVH_WIDTH];
} Walk;

INLINE void walk_start(Walk *w, const Geometry *g, Ray r, float t_min, float t_max, bool any_hit) {
    w->r = r; w->t_min = t_min; w->t_max = t_max;
    w->best = no_hit(); w->best.t = t_max; w->T = 1.0f;
    w->sp = 0; w->overflow = false; w->visits = 0;
    if (g->n_prims > 0) {
        COUNT_NODE(&w->visits);
        w->sp = push_lanes(0, hit_boxes(r, (__global const lanes_f *)g->nodes, t_max), any_hit, w->stack_key,
                           w->stack_node, 0, &w->overflow);
    }
}

/* Visit the lane on top of the stack: a leaf's blocks are tested, a node's boxes tested and its hit
 * lanes pushed.  Call while w->sp > 0, with the any_hit the walk started with (a constant at every
 * call, so the compiler keeps one kind of walk per loop). */
INLINE void walk_step(Walk *w, const Geometry *g, bool opaque_only, bool any_hit) {
    __global const float4 *nodes = g->nodes;
    __global const int *ints = (__global const int *)nodes;
    int sp = --w->sp;
    uint key = w->stack_key[sp];
    float t_max = any_hit ? w->t_max : w->best.t;
    if (!any_hit && key_t(key) > t_max * 1.0000004f) return; /* beyond the nearest hit so far */
    int node = w->stack_node[sp], lane = key_lane(key, any_hit);
    int child = ints[NODE_FLOATS * node + CHILD_ROW + lane], count = ints[NODE_FLOATS * node + COUNT_ROW + lane];
    if (count < 0) return; /* an empty lane: only a NaN ray meets its [+inf, -inf] box; never descend */
    COUNT_NODE(&w->visits);
    if (count > 0) {
        COUNT_PRIMS(&w->visits, count); /* any-hit: at most, it stops at the first opaque hit */
        if (any_hit) {
            w->T *= blocks_transmittance(g, child, count, w->r, w->t_min, t_max, opaque_only);
            if (w->T == 0.0f) w->sp = 0; /* blocked: done */
        } else {
            test_blocks(nodes, child, count, g->prims, w->r, w->t_min, &w->best);
        }
    } else {
        w->sp = push_lanes(child, hit_boxes(w->r, (__global const lanes_f *)nodes + 8 * child, t_max), any_hit,
                           w->stack_key, w->stack_node, sp, &w->overflow);
    }
}

/* After the last step: a lane that did not fit on the stack means every primitive is tested instead. */
INLINE void walk_finish(Walk *w, const Geometry *g, bool opaque_only, bool any_hit) {
    if (!w->overflow) return;
    if (any_hit) {
        if (w->T == 0.0f) return;
        w->T = 1.0f;
        for (int s = 0; s < g->n_prims && w->T > 0.0f; ++s)
            w->T *= crossing_transmittance(g, s, w->r, w->t_min, w->t_max, opaque_only);
    } else {
        test_slots(g->prims, 0, g->n_prims, w->r, w->t_min, &w->best);
    }
}

INLINE Hit closest_hit_wide(const Geometry *g, Ray r, float t_min, float t_max, uint *visits) {
    Walk w;
    walk_start(&w, g, r, t_min, t_max, false);
    while (w.sp > 0) walk_step(&w, g, true, false);
    walk_finish(&w, g, true, false);
    *visits += w.visits;
    return w.best;
}

INLINE float transmittance_wide(const Geometry *g, Ray r, float t_min, float t_max, bool opaque_only, uint *visits) {
    Walk w;
    walk_start(&w, g, r, t_min, t_max, true);
    while (w.sp > 0) walk_step(&w, g, opaque_only, true);
    walk_finish(&w, g, opaque_only, true);
    *visits += w.visits;
    return w.T;
}
#endif

INLINE Hit closest_hit(const Geometry *g, Ray r, float t_min, float t_max, uint *visits) {
    __global const float4 *nodes = g->nodes, *prims = g->prims;
    int n_prims = g->n_prims;
    Hit best = no_hit();
    best.t = t_max;
#if USE_BVH && BVH_WIDTH == 2
    /* the builder keeps trees at most clrender.trace.bvh.MAX_TREE_LEVELS deep, so near-first traversal holds
       at most depth - 1 far nodes; should a stack ever fill up anyway, no node is dropped: the
       primitives are then all tested (the answer is the same, only slower) */
    int stack[STACK_SIZE];
    float stack_t[STACK_SIZE];
    int sp = 0;
    bool overflow = false;
    int node = (n_prims > 0 && hit_box(r, nodes[0], nodes[1], best.t) != INF_T) ? 0 : -1;
    while (node >= 0) {
        COUNT_NODE(visits);
        float4 lo = nodes[BVH_NODE_ROWS * node], hi = nodes[BVH_NODE_ROWS * node + 1];
        int count = as_int(hi.w), offset = as_int(lo.w);
        int next = -1;
        if (count > 0) {
            COUNT_PRIMS(visits, count);
            test_slots(prims, offset, offset + count, r, t_min, &best);
        } else {
            int near_child = node + 1, far_child = offset;
            float t_near = hit_box(r, nodes[BVH_NODE_ROWS * near_child], nodes[BVH_NODE_ROWS * near_child + 1], best.t);
            float t_far = hit_box(r, nodes[BVH_NODE_ROWS * far_child], nodes[BVH_NODE_ROWS * far_child + 1], best.t);
            if (t_far < t_near) { /* visit the nearer box first */
                int tmp = near_child; near_child = far_child; far_child = tmp;
                float tt = t_near; t_near = t_far; t_far = tt;
            }
            if (t_near != INF_T) {
                next = near_child;
                if (t_far != INF_T) { /* put far node on the stack */
                    if (sp < STACK_SIZE) { stack[sp] = far_child; stack_t[sp] = t_far; ++sp; }
                    else overflow = true;
                }
            }
        }
        /* advance to the near node, else pop a far node the ray can still reach */
        while (next < 0 && sp > 0) {
            --sp;
            if (stack_t[sp] <= best.t * 1.0000004f) next = stack[sp];
        }
        node = next;
    }
    if (overflow) test_slots(prims, 0, n_prims, r, t_min, &best);
#elif USE_BVH
    best = closest_hit_wide(g, r, t_min, t_max, visits);
#else
    test_slots(prims, 0, n_prims, r, t_min, &best);
    *visits += (uint)n_prims;
#endif
    if (best.slot < 0) best = no_hit();
    return best;
}

INLINE float transmittance(const Geometry *g, Ray r, float t_min, float t_max, bool opaque_only, uint *visits) {
    __global const float4 *nodes = g->nodes;
    int n_prims = g->n_prims;
    float T = 1.0f;
#if USE_BVH && BVH_WIDTH >= 4
    T = transmittance_wide(g, r, t_min, t_max, opaque_only, visits);
#elif USE_BVH
    int stack[STACK_SIZE]; /* holds at most the tree's depth; on overflow see below */
    int sp = 0;
    bool overflow = false;
    if (n_prims > 0 && hit_box(r, nodes[0], nodes[1], t_max) != INF_T) stack[sp++] = 0;
    while (sp > 0 && T > 0.0f) {
        int node = stack[--sp];
        COUNT_NODE(visits);
        float4 lo = nodes[BVH_NODE_ROWS * node], hi = nodes[BVH_NODE_ROWS * node + 1];
        int count = as_int(hi.w), offset = as_int(lo.w);
        if (count > 0) {
            COUNT_PRIMS(visits, count); /* at most: the loop stops at the first opaque hit */
            for (int s = offset; s < offset + count && T > 0.0f; ++s)
                T *= crossing_transmittance(g, s, r, t_min, t_max, opaque_only);
        } else {
            int children[2] = {node + 1, offset};
            for (int k = 0; k < 2; ++k) {
                int child = children[k];
                if (hit_box(r, nodes[BVH_NODE_ROWS * child], nodes[BVH_NODE_ROWS * child + 1], t_max) != INF_T) {
                    if (sp < STACK_SIZE) stack[sp++] = child;
                    else overflow = true;
                }
            }
        }
    }
    if (overflow && T > 0.0f) { /* a node did not fit on the stack: test every primitive instead */
        T = 1.0f;
        for (int s = 0; s < n_prims && T > 0.0f; ++s)
            T *= crossing_transmittance(g, s, r, t_min, t_max, opaque_only);
    }
#else
    for (int s = 0; s < n_prims && T > 0.0f; ++s)
        T *= crossing_transmittance(g, s, r, t_min, t_max, opaque_only);
    *visits += (uint)n_prims;
#endif
    return T;
}

#pragma OPENCL FP_CONTRACT ON /* the default again, for the files that follow */

#endif
