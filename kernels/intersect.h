/* Ray-primitive tests and BVH traversal: the closest hit of a ray, and the light a shadow ray lets
 * through (any-hit: transmittance, which an opaque surface ends).
 *
 * One walker (kernels/walk.h), included once per tree, walked state and kind: for one ray (kernels/ray_walks.h,
 * included here once per kind) a mesh's tree (mesh_walk_*; wide or binary nodes by BVH_WIDTH) and the instances'
 * top tree (top_walk_*; wide or binary by TOP_WIDE), each with its leaf hook (mesh_leaf: leaf_blocks or
 * leaf_slots; top_leaf: visit_instance) and its fallback for a full stack.  Closest hit and any-hit are separate
 * functions (_closest, _any), and what a shadow ray keeps at a surface is the walk's `pass` (Pass), a constant at
 * every call, so the compiler keeps one specialised copy of each.  The entry points closest_hit and
 * transmittance answer the BVH-off path too.  The other states the walker walks (measured speeds:
 * docs/benchmarks.md, "Ray queries"):
 * - Packet (kernels/packet.h): eight rays that go the same way walk the wide tree together, one stack
 *   and one box sort for all, each triangle tested against eight rays in float8 lanes; the query
 *   kernels walk rays that do not as groups of four stepped walks (packets: about 1.7x for coherent rays).
 * - Shaft (kernels/shaft.h): a shading point's shadow rays toward an area light share one walk
 *   of the shaft that holds them all, then test only the primitives it collected (about 2x fewer
 *   CPU-seconds for soft shadows). */
#ifndef CLRENDER_INTERSECT_H
#define CLRENDER_INTERSECT_H

#include "common.h"

/* No contraction of a*b + c into fma here: the one-triangle and the block tests must round alike. */
#pragma OPENCL FP_CONTRACT OFF

typedef struct {
    float t;       /* distance along the (unit) direction; INF_T on a miss */
    int slot;      /* index into the slots; -1 on a miss */
    int id;        /* primitive id in scene order; -1 on a miss */
    float u, v;    /* barycentrics of v1 and v2 on a triangle */
#if INSTANCED
    int instance;  /* the Instance hit (its slot and u, v are the mesh's, in object space); -1: the flat part */
#endif
} Hit;

/* A hit a lane: the walks' Hit at width 1 (kernels/lanes.h), what the surface pipeline (surface_at) reads */
#if LANES == 1
typedef Hit HitL;
#else
typedef struct {
    LF t;
    LI slot, id;
    LF u, v;
#if INSTANCED
    LI instance;
#endif
} HitL;
#endif

/* The lanes whose hit is on an instance (none in a flat scene). */
INLINE LI placed(HitL h) {
#if INSTANCED
    return h.instance >= 0;
#else
    return 0;
#endif
}

#if INSTANCED
/* Each lane's instance, instance 0 in the lanes whose hit is on none: an index every lane's gather may read (nothing
 * keeps what those lanes find). */
INLINE LI instance_index(HitL h) { return placed(h) ? h.instance : (LI)(0); }
#endif

#if LANES > 1
/* h in the lanes of `keep`, the flat part's primitive 0 in the others: a hit every lane's reads may take (in lanes the
 * shading reads every lane's records; nothing keeps what the others find). */
INLINE HitL kept_hits(HitL h, LI keep) {
    h.slot = keep ? h.slot : (LI)(0);
    h.id = keep ? h.id : (LI)(0);
#if INSTANCED
    h.instance = keep ? h.instance : (LI)(-1);
#endif
    return h;
}
#endif

/* Whether a hit at t on primitive `id` replaces *best: nearer, or as near and a lower id (ties go to the
 * lowest primitive id, whatever the walk's order). */
INLINE bool nearer_hit(float t, int id, const Hit *best) { return t < best->t || (t == best->t && id < best->id); }

/* The tree's node record (clrender/layout.py), by BVH_WIDTH. */
#if BVH_WIDTH == 2
typedef BvhNode TreeNode;
#else
#if BVH_WIDTH == 4
typedef WideNode4 WideNode;
#else
typedef WideNode8 WideNode;
#endif
typedef WideNode TreeNode;
#endif

#if INSTANCED
/* The top level's node record: -DTOP_WIDE=1 (wide mesh trees and a top tree of more than one node), the
 * wide walks' (clrender/trace/tracer.py _top collapses the binary tree over the instances' boxes, a leaf
 * lane's child the first instance and count how many), else binary. */
#if TOP_WIDE
typedef WideNode TopNode;
#else
typedef BvhNode TopNode;
#endif
#endif

/* The scene's geometry as every traversal reads it (packed by clrender/trace/tracer.py). */
typedef struct {
    __global const TreeNode *nodes;    /* the tree, node 0 its root; a wide tree's leaf blocks follow its nodes (leaf_block) */
    __global const PrimSlot *slots;    /* primitive slots, in the tree's leaf order: prim_slot, sphere_slot */
    __global const int *prim_object;   /* object id of each primitive id */
    __global const ObjectRecord *objects; /* per object: its material, smooth flag (the shading reads them) */
    int n_prims;
#if INSTANCED
    __global const Instance *instances; /* each names its mesh's tree and slots, in the top tree's leaf order */
    __global const TopNode *top;        /* the top level: a tree over the instances' world boxes (TopNode) */
    int n_instances;
    int object;                         /* an instance's Geometry (instance_geometry): its object; -1: the flat part */
#endif
} Geometry;

/* The kernels' buffers as a Geometry. */
INLINE Geometry geometry(__global const TreeNode *nodes, __global const PrimSlot *prims, __global const int *prim_object,
                         __global const ObjectRecord *objects, int n_prims) {
    Geometry g;
    g.nodes = nodes; g.slots = prims; g.prim_object = prim_object; g.objects = objects;
    g.n_prims = n_prims;
#if INSTANCED
    g.instances = 0; g.top = 0; g.n_instances = 0; g.object = -1; /* the kernels' with_instances sets them */
#endif
    return g;
}

/* The kernels' instances (-DINSTANCED=1; without, none are read and n_instances is 0). */
INLINE void with_instances(Geometry *g, __global const Instance *instances, __global const BvhNode *top,
                           int n_instances) {
#if INSTANCED
    g->instances = instances;
    g->top = (__global const TopNode *)top; /* the kernels' `top` argument holds TopNode records */
    g->n_instances = n_instances;
#endif
}

/* Slot s: a triangle's record, or the same 48 bytes as a sphere's (`sphere` tells which). */
INLINE __global const PrimSlot *prim_slot(const Geometry *g, int s) { return g->slots + s; }
INLINE __global const SphereSlot *sphere_slot(const Geometry *g, int s) { return (__global const SphereSlot *)(g->slots + s); }

/* Three floats of a record (an array field) as a float3. */
INLINE float3 load3(__global const float *xyz) { return (float3)(xyz[0], xyz[1], xyz[2]); }

/* A sphere slot's centre and radius, as the sphere tests take them. */
INLINE float4 centre_radius(__global const SphereSlot *s) { return (float4)(load3(s->centre), s->radius); }

/* Lane k of a vector field in global memory, read as an array: OpenCL C cannot index a vector by a variable. */
#define LANE_OF(type, vector, k) (((__global const type *)&(vector))[k])

#if BVH_WIDTH >= 4
/* The leaf block a wide leaf lane's child names: blocks are counted in LeafBlocks from the start of
 * the nodes' buffer (clrender/trace/bvh_wide.py tree_buffer puts them after the nodes). */
INLINE __global const LeafBlock *leaf_block(const Geometry *g, int first) { return (__global const LeafBlock *)g->nodes + first; }
#endif

/* An any-hit walk's leaf hook: what a shadow ray keeps of the light at each surface it crosses.  Opaque
 * (opaque_pass: occlusion queries, the path tracer's shadow rays): nothing, the walk ends at the first
 * crossing.  Otherwise (material_pass: the Whitted integrator's transparent shadows, kernels/shade.h) the
 * crossed object's material transparency, which the walk multiplies in its own order.  A value whose
 * `opaque` is a constant at each call, so every walk is compiled for one kind. */
typedef struct {
    bool opaque;
    __global const Material *materials; /* not opaque: the scene's materials, which Geometry does not carry */
} Pass;

INLINE Pass opaque_pass(void) { Pass p; p.opaque = true; p.materials = 0; return p; }
INLINE Pass material_pass(__global const Material *materials) { Pass p; p.opaque = false; p.materials = materials; return p; }

/* What a shadow ray keeps crossing primitive `id` (its material's transparency, by pass). */
INLINE float transparency_of(const Geometry *g, Pass pass, int id) {
#if INSTANCED
    if (g->object >= 0) return pass.materials[g->objects[g->object].material].transparency; /* id is the mesh's own */
#endif
    return pass.materials[g->objects[g->prim_object[id]].material].transparency;
}


INLINE Hit no_hit(void) {
    Hit h;
    h.t = INF_T; h.slot = -1; h.id = -1; h.u = 0.0f; h.v = 0.0f;
#if INSTANCED
    h.instance = -1;
#endif
    return h;
}

#define GAMMA(n) ((float)(n) * 5.96046448e-8f / (1.0f - (float)(n) * 5.96046448e-8f)) /* n*u/(1-n*u), u = 2^-24 */

/* A box's exit distance is widened by 1 + 2 gamma(3) (pbrt-v4's Bounds3::IntersectP): each slab
 * distance (b - o) * inv_d is within gamma(3) of the exact one, entry and exit alike, so a box a hit
 * lies in is never culled by rounding.  1 + 2 gamma(3) = 1 + 3.5763e-7 rounds to 1 + 3 * 2^-23 in
 * float32, which is what 1.0000004f reads as.  The same factor culls a stacked box against the
 * nearest hit so far: it is dropped only when hit_box, given that hit's t as t_max, would miss it. */
#define BOX_EXIT_WIDEN 1.0000004f
/* The t range a primitive is tested in while a nearest hit t is known: t * (1 + 2^-22), two ulps
 * more (1.0000002f reads as 1 + 2 * 2^-23).  A primitive at exactly t must still be found, for ties
 * go to the lower primitive id: the triangle test refuses t >= t_max and compares t * det with
 * t_max * det before its one division, each rounding half an ulp, so without the slack a tie could
 * be refused by rounding.  The caller's exact comparison then decides (leaf_slots, nearest_lane). */
#define HIT_TIE_WIDEN 1.0000002f

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

/* One triangle (vertices v0, v1, v2): t in (t_min, t_max) or INF_T, and u, v. */
INLINE float hit_triangle(Ray r, float3 v0, float3 v1, float3 v2, float t_min, float t_max, float *u, float *v) {
    float3 q0 = v0 - r.o, q1 = v1 - r.o, q2 = v2 - r.o;
    return triangle_test(axis_of(q0, r.kx), axis_of(q0, r.ky), axis_of(q0, r.kz), axis_of(q1, r.kx),
                         axis_of(q1, r.ky), axis_of(q1, r.kz), axis_of(q2, r.kx), axis_of(q2, r.ky),
                         axis_of(q2, r.kz), 1, r.sx, r.sy, r.sz, t_min, t_max, u, v);
}

#if BVH_WIDTH >= 4
/* The triangles of a leaf block, in lanes where `valid` is set: the same operations as hit_triangle,
 * lane by lane. */
INLINE float4 hit_block(Ray r, __global const LeafBlock *b, int4 valid, float t_min, float t_max, float4 *u, float4 *v) {
    float ox = axis_of(r.o, r.kx), oy = axis_of(r.o, r.ky), oz = axis_of(r.o, r.kz);
    return triangle_test4(b->v0[r.kx] - ox, b->v0[r.ky] - oy, b->v0[r.kz] - oz, b->v1[r.kx] - ox, b->v1[r.ky] - oy,
                          b->v1[r.kz] - oz, b->v2[r.kx] - ox, b->v2[r.ky] - oy, b->v2[r.kz] - oz, valid, r.sx, r.sy,
                          r.sz, t_min, t_max, u, v);
}
#endif

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
INLINE V3 hit_point_triangle(V3 v0, V3 v1, V3 v2, LF u, LF v, V3 *p_err) {
    LF b0 = 1.0f - u - v;
    V3 a0 = vscale(b0, v0), a1 = vscale(u, v1), a2 = vscale(v, v2);
    *p_err = v3(GAMMA(7) * (abs_l(a0.x) + abs_l(a1.x) + abs_l(a2.x)), GAMMA(7) * (abs_l(a0.y) + abs_l(a1.y) + abs_l(a2.y)),
                GAMMA(7) * (abs_l(a0.z) + abs_l(a1.z) + abs_l(a2.z)));
    return vadd(vadd(a0, a1), a2);
}

/* The hit point on a sphere, moved onto the surface along the radius
 * (pbrt-v4's reprojection), and a bound on its float32 error per axis. */
INLINE V3 hit_point_sphere(V3 centre, LF radius, V3 p_ray, V3 *p_err) {
    V3 rel = vsub(p_ray, centre);
    rel = vscale(radius / sqrt_l(vdot(rel, rel)), rel);
    V3 p = vadd(centre, rel);
    *p_err = v3(GAMMA(5) * abs_l(rel.x) + GAMMA(2) * abs_l(p.x), GAMMA(5) * abs_l(rel.y) + GAMMA(2) * abs_l(p.y),
                GAMMA(5) * abs_l(rel.z) + GAMMA(2) * abs_l(p.z));
    return p;
}


/* Distance to primitive slot s in (t_min, t_max), or INF_T; u, v set on a triangle hit. */
INLINE float hit_slot(const Geometry *g, int s, Ray r, float t_min, float t_max, float *u, float *v) {
    __global const PrimSlot *p = prim_slot(g, s);
    if (p->sphere) return hit_sphere(r, centre_radius(sphere_slot(g, s)), t_min, t_max);
    return hit_triangle(r, load3(p->v0), load3(p->v1), load3(p->v2), t_min, t_max, u, v);
}

/* Fraction of light reaching t_max along the ray through slot s: 0 past an opaque surface, times
 * `transparency` for every crossing of a transparent one (the shadow ray is not bent).  With an
 * opaque pass every surface blocks (a plain any-hit occlusion query). */
INLINE float crossing_transmittance(const Geometry *g, int s, Ray r, float t_min, float t_max, Pass pass) {
    __global const PrimSlot *p = prim_slot(g, s);
    int crossings = 0;
    if (p->sphere) {
        float t0, t1;
        float4 cr = centre_radius(sphere_slot(g, s));
        if (sphere_roots(r, cr, &t0, &t1)) {
            float t_lo = max_f(t_min, sphere_t_eps(r, cr));
            crossings = (t0 > t_lo && t0 < t_max) + (t1 > t_lo && t1 < t_max);
        }
    } else {
        float u, v;
        crossings = hit_triangle(r, load3(p->v0), load3(p->v1), load3(p->v2), t_min, t_max, &u, &v) != INF_T;
    }
    if (crossings == 0) return 1.0f;
    if (pass.opaque) return 0.0f;
    float transparency = transparency_of(g, pass, p->id);
    return crossings == 2 ? transparency * transparency : transparency;
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

/* Slab test of a binary node's box; returns the entry distance or INF_T.  Correct for every
 * direction, zero and negative-zero components included, and conservative: the exit distance is
 * widened by BOX_EXIT_WIDEN.  Scalars: float3 arithmetic costs shuffles on CPUs. */
INLINE float hit_box(Ray r, __global const BvhNode *node, float t_max) {
    float t_enter = 0.0f, t_exit = t_max;
    slab(node->bmin[0], node->bmax[0], r.o.x, r.inv_d.x, &t_enter, &t_exit);
    slab(node->bmin[1], node->bmax[1], r.o.y, r.inv_d.y, &t_enter, &t_exit);
    slab(node->bmin[2], node->bmax[2], r.o.z, r.inv_d.z, &t_enter, &t_exit);
    t_exit *= BOX_EXIT_WIDEN;
    return t_enter <= t_exit ? t_enter : INF_T;
}

/* ---------------------------------------------------------------- wide BVH (clrender/trace/bvh_wide.py)
 * BVH_WIDTH 4 or 8.  A node (WideNode, clrender/layout.py) holds its children in BVH_WIDTH lanes of
 * OpenCL vectors (float4 or float8 fields, read as typed vectors: vloadN here was 17% slower on
 * PoCL): bounds[2 axis], bounds[2 axis + 1] their lo and hi along each axis, child (a wide node, or a
 * leaf's first block) and count (0 interior, > 0 leaf primitives, -1 empty lane).  The slab test is
 * hit_box's, lane by lane: the same float operations, so each lane's answer is bit for bit the binary
 * test's for that box.  Stack entries are lane keys (lane_keys) with their node; see Walk. */
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

/* One axis of the box test for every lane: the near plane's bounds are `near_plane` (lo, or hi for a
 * ray going backwards along the axis: the fields are picked by index, not by selecting results), the
 * far plane's the other.  A NaN lane of the entry distance (0 * inf: the ray runs in a box plane) keeps
 * t_enter, as max_f does; ?: rather than select(), which PoCL calls out of line. */
INLINE void slab_lanes(lanes_f near_plane, lanes_f far_plane, float o, float inv_d, lanes_f *t_enter,
                       lanes_f *t_exit) {
    lanes_f near = (near_plane - o) * inv_d, far = (far_plane - o) * inv_d;
    *t_enter = near > *t_enter ? near : *t_enter;
    *t_exit = far < *t_exit ? far : *t_exit;
}

/* Entry distances of the lanes of a node (INF_T where the box is missed or the lane is empty).
 * bounds[2a] and bounds[2a + 1] hold lo and hi along axis a; the sign of 1/d picks which is near. */
INLINE lanes_f hit_boxes(Ray r, __global const WideNode *node, float t_max) {
    int bx = r.inv_d.x < 0.0f, by = r.inv_d.y < 0.0f, bz = r.inv_d.z < 0.0f; /* -0 counts as backwards */
    __global const lanes_f *b = node->bounds;
    lanes_f t_enter = (lanes_f)(0.0f), t_exit = (lanes_f)(t_max);
    slab_lanes(b[bx], b[1 - bx], r.o.x, r.inv_d.x, &t_enter, &t_exit);
    slab_lanes(b[2 + by], b[3 - by], r.o.y, r.inv_d.y, &t_enter, &t_exit);
    slab_lanes(b[4 + bz], b[5 - bz], r.o.z, r.inv_d.z, &t_enter, &t_exit);
    t_exit *= BOX_EXIT_WIDEN;
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

/* Push the hit lanes of `node`: their keys sorted so that the top of the stack is the nearest
 * (closest hit) or the farthest (any-hit: the boxes nearest a shadow ray's origin rarely block
 * it).  All BVH_WIDTH keys are written (the arrays have that much slack), the stack grows by
 * the number of hits.  No branch per lane: which lanes hit is unpredictable.  `sort_always`: no
 * branch on the number of hits either, every node's keys go through the sort: for incoherent
 * rays whether 0, 1 or more lanes hit is a coin toss decided only at the end of the box test's
 * dependent chain (the query kernels' stepped walks: 3.39 -> 3.70 Mrays per CPU-second), while
 * a render's coherent rays predict it and gain from skipping the sort (bunny render: 4% less CPU)
 * (docs/bvh.md, "Incoherent rays: ordering, vectorisation, branches").  The same entries either way. */
INLINE int push_lanes(int node, lanes_f t_lanes, bool farthest_first, bool sort_always, uint *stack_key, int *stack_node,
                      int sp, bool *overflow) {
    lanes_u keys = lane_keys(t_lanes, farthest_first);
    int n = hit_count(keys != (lanes_u)(0u));
    if (!sort_always && n == 0) return sp;
    if (sp + n > WIDE_STACK_SIZE) { *overflow = true; return sp; }
    if (!sort_always && n == 1) { /* one hit lane: no sort */
        stack_key[sp] = max_key(keys); stack_node[sp] = node;
        return sp + 1;
    }
    keys = sort_keys_decreasing(keys);
    uint k[BVH_WIDTH] = LANES_ARRAY(keys);
    for (int j = 0; j < BVH_WIDTH; ++j) { stack_key[sp + j] = k[j]; stack_node[sp + j] = node; }
    return sp + n;
}

/* Closest hit in one leaf block: of the lanes' hits t (INF_T where none), the nearest is kept in *best
 * as leaf_slots keeps it: the same t, and ties to the lower primitive id. */
INLINE void nearest_lane(const Geometry *g, int4 slot, float4 t, float4 u, float4 v, Hit *best) {
    float2 m2 = t.lo < t.hi ? t.lo : t.hi;
    if (min_f(m2.x, m2.y) > best->t) return; /* no lane hit */
    float tl[4] = {t.x, t.y, t.z, t.w}, ul[4] = {u.x, u.y, u.z, u.w}, vl[4] = {v.x, v.y, v.z, v.w};
    int sl[4] = {slot.x, slot.y, slot.z, slot.w};
    for (int k = 0; k < BLOCK_LANES; ++k) {
        if (tl[k] == INF_T) continue;
        int id = prim_slot(g, sl[k])->id;
        if (nearer_hit(tl[k], id, best)) {
            best->t = tl[k]; best->slot = sl[k]; best->id = id; best->u = ul[k]; best->v = vl[k];
        }
    }
}

/* T times the transparency of every triangle lane of `block` the ray crosses (a hit t in that lane),
 * in lane order: a triangle is crossed once. */
INLINE float times_crossed(const Geometry *g, Pass pass, __global const LeafBlock *block, float4 t, float T) {
    int4 crossed = t != (float4)(INF_T);
    if (!(crossed.x | crossed.y | crossed.z | crossed.w)) return T;
    int4 slot = block->slot;
    int cl[4] = {crossed.x, crossed.y, crossed.z, crossed.w}, sl[4] = {slot.x, slot.y, slot.z, slot.w};
    for (int k = 0; k < BLOCK_LANES; ++k)
        if (cl[k]) T *= transparency_of(g, pass, prim_slot(g, sl[k])->id);
    return T;
}

/* A ray's walk through the wide tree, as a state a work-item can advance one stack entry at a time:
 * the ray kernels step four rays in turn, whose steps do not depend on each other, so the CPU overlaps
 * one's memory and branch latencies with the others' work (two: +10-15% per ray measured; four: 6% more).  Closest hit:
 * `best` shrinks the search as hits are found; any-hit (shadow rays): `T` is the light getting
 * through so far, and the walk ends at an opaque hit.  Stack entries are lane keys (lane_keys) with
 * the node they belong to; trees are at most clrender.trace.bvh.MAX_TREE_LEVELS deep, so the stack
 * holds at most BVH_WIDTH - 1 siblings per level plus one node's lanes
 * (clrender.trace.knobs.TraceKnobs.wide_stack_size); should it fill up, WALK_EVERY at the end (walk.h). */
typedef struct {
    Ray r;
    float t_min, t_max; /* any-hit: the segment; closest hit: t_max is the nearest hit so far */
    Hit best;
    float T;
    int sp;
    bool overflow;
    bool sort_always;   /* push_lanes' choice: true for the query kernels' walks (query_walk_start), false for renders (walk_tree) */
    uint visits;
    uint stack_key[WIDE_STACK_SIZE + BVH_WIDTH];
    int stack_node[WIDE_STACK_SIZE + BVH_WIDTH];
} Walk;

#endif

#if INSTANCED
#ifndef INSTANCE_SORT_ALWAYS
#define INSTANCE_SORT_ALWAYS false
#endif
/* ---------------------------------------------------------------- instances (clrender/trace/instancing.py)
 * -DINSTANCED=1: meshes that several objects place are stored once, each with its own tree in object
 * space after the flat part's tree in the nodes' buffer, and g->instances place them.  A ray meets the
 * flat part first, then the instances whose world boxes it enters (the top level, g->top: a binary
 * tree over those boxes), each in object space: origin and direction by world_to_object, the
 * direction NOT renormalised, so t is the world t and hits compare across instances.  Spheres stay
 * flat (their test wants a unit direction).  The query kernels walk eight rays that go the same way as
 * packets (packet.h, "instanced packets"), others one at a time here; the render kernels walk one ray at a
 * time (no shadow shafts, shaft.h), and shade a hit by instance_surface. */
INLINE float3 affine_point(__global const float *m, float3 p) {
    return (float3)(m[0] * p.x + m[1] * p.y + m[2] * p.z + m[3], m[4] * p.x + m[5] * p.y + m[6] * p.z + m[7],
                    m[8] * p.x + m[9] * p.y + m[10] * p.z + m[11]);
}
INLINE float3 affine_vector(__global const float *m, float3 v) {
    return (float3)(m[0] * v.x + m[1] * v.y + m[2] * v.z, m[4] * v.x + m[5] * v.y + m[6] * v.z,
                    m[8] * v.x + m[9] * v.y + m[10] * v.z);
}

/* hit_box's slab test on a world box: its entry distance or INF_T. */
INLINE float hit_bounds(Ray r, __global const float *lo, __global const float *hi, float t_max) {
    float t_enter = 0.0f, t_exit = t_max;
    slab(lo[0], hi[0], r.o.x, r.inv_d.x, &t_enter, &t_exit);
    slab(lo[1], hi[1], r.o.y, r.inv_d.y, &t_enter, &t_exit);
    slab(lo[2], hi[2], r.o.z, r.inv_d.z, &t_enter, &t_exit);
    t_exit *= BOX_EXIT_WIDEN;
    return t_enter <= t_exit ? t_enter : INF_T;
}

/* Instance i's mesh as a Geometry of its own: its tree (self-relative, as the builder wrote it) and slots. */
INLINE Geometry instance_geometry(const Geometry *g, __global const Instance *in) {
    Geometry s = *g;
    s.nodes = (__global const TreeNode *)((__global const char *)g->nodes + in->node_bytes);
    s.slots = g->slots + in->slot_base;
    s.n_prims = in->n_prims;
    s.object = in->object;
    return s;
}
#endif

/* One ray's walks, once per kind (kernels/ray_walks.h): closest hit (the _closest functions) and any-hit (_any). */
#define ANY_HIT 0
#define KIND(f) f##_closest
#include "ray_walks.h"
#define ANY_HIT 1
#define KIND(f) f##_any
#include "ray_walks.h"

INLINE Hit closest_hit(const Geometry *g, Ray r, float t_min, float t_max, uint *visits) {
    Hit best;
    float T;
    trace_query_closest(g, r, t_min, t_max, opaque_pass(), &best, &T, visits);
    return best.slot < 0 ? no_hit() : best;
}

/* Fraction of light reaching t_max along the ray: 0 past an opaque surface, times the transparency of
 * every crossing of a transparent one; with pass every surface blocks. */
INLINE float transmittance(const Geometry *g, Ray r, float t_min, float t_max, Pass pass, uint *visits) {
    Hit best;
    float T;
    trace_query_any(g, r, t_min, t_max, pass, &best, &T, visits);
    return T;
}

#pragma OPENCL FP_CONTRACT ON /* the default again, for the files that follow */

/* The scene object a hit belongs to: its instance's, or its flat primitive's; -1 on a miss. */
INLINE LI hit_object(const Geometry *g, HitL h) {
#if LANES == 1
#if INSTANCED
    if (h.instance >= 0) return g->instances[h.instance].object;
#endif
    return h.id >= 0 ? g->prim_object[h.id] : -1;
#else
    LI on_instance = placed(h), flat = (h.id >= 0) & NOT(on_instance);
    LI object = flat ? gather_i(g->prim_object, flat ? h.id : (LI)(0)) : (LI)(-1);
#if INSTANCED
    WHERE(on_instance, object, FIELD_I(g->instances, instance_index(h), object));
#endif
    return object;
#endif
}

/* Where hit h's per-primitive records are (vertex normals, VertexAttributes): its primitive id, or for an
 * instance its mesh's records, stored once for all its instances (Instance.data_base + the mesh's own id). */
INLINE LI hit_data(const Geometry *g, HitL h) {
    LI data = h.id;
#if INSTANCED
    LI i = instance_index(h);
    WHERE(placed(h), data, FIELD_I(g->instances, i, data_base) + (h.id - FIELD_I(g->instances, i, prim_base)));
#endif
    return data;
}

#if INSTANCED
/* Each lane's instance's 3x4 map, row-major: world_to_object (`to_object`) or object_to_world. */
typedef struct {
    LF m[12];
} InstanceMap;

INLINE InstanceMap instance_map(const Geometry *g, LI i, bool to_object) {
    InstanceMap a;
    for (int k = 0; k < 12; ++k)
        a.m[k] = to_object ? FIELD_F(g->instances, i, world_to_object[k / 4][k % 4]) : FIELD_F(g->instances, i, object_to_world[k / 4][k % 4]);
    return a;
}

/* An object-space normal n in world space: by the inverse transpose (`w`: world_to_object, transposed here),
 * renormalised (outward stays outward under mirrors too: no winding is involved). */
INLINE V3 normal_to_world(const InstanceMap *w, V3 n) {
    const LF *m = w->m;
    return vunit(v3(m[0] * n.x + m[4] * n.y + m[8] * n.z, m[1] * n.x + m[5] * n.y + m[9] * n.z, m[2] * n.x + m[6] * n.y + m[10] * n.z));
}

/* The linear part of a map applied to vector v (a tangent). */
INLINE V3 map_vector(const InstanceMap *a, V3 v) {
    const LF *m = a->m;
    return v3(m[0] * v.x + m[1] * v.y + m[2] * v.z, m[4] * v.x + m[5] * v.y + m[6] * v.z, m[8] * v.x + m[9] * v.y + m[10] * v.z);
}

/* |M| x for the linear part of a map (error bounds). */
INLINE V3 abs_linear(const InstanceMap *a, V3 x) {
    const LF *m = a->m;
    return v3(abs_l(m[0]) * x.x + abs_l(m[1]) * x.y + abs_l(m[2]) * x.z, abs_l(m[4]) * x.x + abs_l(m[5]) * x.y + abs_l(m[6]) * x.z,
              abs_l(m[8]) * x.x + abs_l(m[9]) * x.y + abs_l(m[10]) * x.z);
}

#pragma OPENCL FP_CONTRACT OFF /* as affine_point, which places the rays' points */
INLINE V3 map_point(const InstanceMap *a, V3 p) {
    const LF *m = a->m;
    return v3(m[0] * p.x + m[1] * p.y + m[2] * p.z + m[3], m[4] * p.x + m[5] * p.y + m[6] * p.z + m[7], m[8] * p.x + m[9] * p.y + m[10] * p.z + m[11]);
}
#pragma OPENCL FP_CONTRACT ON

/* hit_surface on an instance, in the lanes whose hit is on one (the others read instance 0's slot h.slot: a slot of
 * it or of another mesh, and nothing keeps what they find): the mesh's triangle in object space, its point placed by
 * object_to_world with the error bound carried along (pbrt-v4's transform of a point with error: (1 + gamma3) |M| err
 * + gamma3 (|M| |p| + |t|)), doubled for the ray's own rounding into object space; the normal by normal_to_world. */
INLINE V3 instance_surface(const Geometry *g, HitL h, V3 *p_err, V3 *n_geo) {
    LI i = instance_index(h);
    LI slot = FIELD_I(g->instances, i, slot_base) + (placed(h) ? h.slot : (LI)(0));
    V3 v0 = FIELD3(g->slots, slot, v0), v1 = FIELD3(g->slots, slot, v1), v2 = FIELD3(g->slots, slot, v2), err;
    V3 p = hit_point_triangle(v0, v1, v2, h.u, h.v, &err);
    InstanceMap to_object = instance_map(g, i, true), to_world = instance_map(g, i, false);
    *n_geo = normal_to_world(&to_object, vcross(vsub(v1, v0), vsub(v2, v0)));
    const LF *m = to_world.m;
    V3 a = abs_linear(&to_world, err), b = abs_linear(&to_world, v3(abs_l(p.x), abs_l(p.y), abs_l(p.z)));
    *p_err = v3(2.0f * ((1.0f + GAMMA(3)) * a.x + GAMMA(3) * (b.x + abs_l(m[3]))), 2.0f * ((1.0f + GAMMA(3)) * a.y + GAMMA(3) * (b.y + abs_l(m[7]))),
                2.0f * ((1.0f + GAMMA(3)) * a.z + GAMMA(3) * (b.z + abs_l(m[11]))));
    return map_point(&to_world, p);
}
#endif

/* (Contracted like the shading code that calls it: a * b + c may become one fma here.) */
/* Where ray (o, d) met slot h.slot (in lanes, each lane's, a sphere's or a triangle's): the hit point and its float32 error, the primitive's unit normal (not
 * yet turned to face the ray: outward, or the winding's), and whether it is a sphere.  The one place the
 * shading of either integrator reads a primitive slot. */
INLINE V3 hit_surface(const Geometry *g, HitL h, V3 o, V3 d, V3 *p_err, V3 *n_geo, LI *sphere) {
#if INSTANCED && LANES == 1
    if (h.instance >= 0) { *sphere = false; return instance_surface(g, h, p_err, n_geo); }
#endif
    *sphere = (FIELD_I(g->slots, h.slot, sphere) != 0) & NOT(placed(h));
    V3 p = *p_err = *n_geo = v3_all(0.0f);
    if (ANY(*sphere)) {
        __global const SphereSlot *spheres = (__global const SphereSlot *)g->slots;
        V3 centre = FIELD3(spheres, h.slot, centre), ray_point = v3(o.x + h.t * d.x, o.y + h.t * d.y, o.z + h.t * d.z);
        V3 err, q = hit_point_sphere(centre, FIELD_F(spheres, h.slot, radius), ray_point, &err);
        p = vpick(*sphere, q, p);
        *p_err = vpick(*sphere, err, *p_err);
        *n_geo = vpick(*sphere, vunit(vsub(q, centre)), *n_geo);
    }
    if (ANY(NOT(*sphere))) {
        V3 v0 = FIELD3(g->slots, h.slot, v0), v1 = FIELD3(g->slots, h.slot, v1), v2 = FIELD3(g->slots, h.slot, v2), err;
        V3 q = hit_point_triangle(v0, v1, v2, h.u, h.v, &err);
        p = vpick(*sphere, p, q);
        *p_err = vpick(*sphere, *p_err, err);
        *n_geo = vpick(*sphere, *n_geo, vunit(vcross(vsub(v1, v0), vsub(v2, v0))));
    }
#if INSTANCED && LANES > 1
    LI on_instance = placed(h);
    if (ANY(on_instance)) {
        V3 err, n, q = instance_surface(g, h, &err, &n);
        p = vpick(on_instance, q, p);
        *p_err = vpick(on_instance, err, *p_err);
        *n_geo = vpick(on_instance, n, *n_geo);
    }
#endif
    return p;
}

#endif
