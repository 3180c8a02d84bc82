/* Ray packets: eight rays that go the same way walk the wide tree together (Wald, Slusallek, Benthin
 * and Wagner 2001; Embree's packet kernels).  A packet pops a node once for all its rays, sorts that
 * node's children once, and tests a leaf's triangles one at a time against all eight rays in float8
 * lanes (rays in the lanes, the triangle the same in each), where a single ray tests four triangles
 * of a block per float4.  The answers are the single-ray walk's bit for bit:
 * - each ray's box tests are hit_boxes' float operations with its own t range, so a ray meets every
 *   box it would meet alone (it may be carried into more: a packet descends where any ray hits);
 * - the triangle test is triangle.h's, lane by lane, and a hit is kept as nearest_lane keeps it (the
 *   nearest, ties to the lower primitive id), so the order boxes are visited in changes nothing.
 * A packet needs its rays to share the signs of their directions (the near plane of every box is the
 * same for all) and the axis of the largest component (the triangle test's permutation); rays that do
 * not, and packets that fill their stack, are walked one by one (Walk) instead.  Spheres in a leaf
 * are tested ray by ray with the lone walk's test.  A packet is a state of the walker (kernels/walk.h), walked by
 * kernels/packet_walks.h once per kind; this file holds the state and its box test and push. */
#ifndef CLRENDER_PACKET_H
#define CLRENDER_PACKET_H

#include "intersect.h"

#if USE_BVH && BVH_WIDTH >= 4

#pragma OPENCL FP_CONTRACT OFF /* as in intersect.h: the lanes must round as the one-ray test does */

#define PACKET_RAYS 8
#define RAY_BITS ((uint8)(1u, 2u, 4u, 8u, 16u, 32u, 64u, 128u)) /* ray k of a packet is bit k of a mask */
#define ALL_RAYS 0xffu
#define FOR_EACH_RAY(X) X(0) X(1) X(2) X(3) X(4) X(5) X(6) X(7)
#define RAY_ARRAY(v) {(v).s0, (v).s1, (v).s2, (v).s3, (v).s4, (v).s5, (v).s6, (v).s7} /* lanes as an array */

INLINE float8 abs8(float8 v) { return as_float8(as_uint8(v) & (uint8)(0x7fffffffu)); }
INLINE int any8(int8 m) {
    int4 m4 = m.lo | m.hi;
    return (m4.x | m4.y | m4.z | m4.w) != 0;
}

/* Rays in lanes (mask bits -> lanes set to -1) and back. */
INLINE int8 ray_lanes(uint bits) { return ((uint8)(bits) & RAY_BITS) != (uint8)(0u); }
INLINE uint ray_bits(int8 lanes) {
    uint8 b = as_uint8(lanes) & RAY_BITS;
    uint4 b4 = b.lo | b.hi;
    uint2 b2 = b4.lo | b4.hi;
    return b2.x | b2.y;
}

/* The triangle test with the packet's rays in the lanes (kernels/triangle.h) */
#define TRI_F float8
#define TRI_I int8
#define TRI_ANY any8
#define TRI_ABS abs8
#define TRI_DOP difference_of_products8
#define TRI_TEST triangle_test8
#define TRI_R float8
#include "triangle.h"

typedef struct {
    float8 ox, oy, oz;          /* origins */
    float8 dx, dy, dz;          /* unit directions */
    float8 ix, iy, iz;          /* 1/d */
    float8 okx, oky, okz;       /* origins with their axes permuted as the triangle test wants */
    float8 sx, sy, sz;          /* the shear (shear_ray) */
    int kx, ky, kz;             /* the shared permutation */
    int bx, by, bz;             /* the shared octant: 1 where the rays go backwards along the axis */
    float8 t_min, t_max;        /* the segment; closest hit: t_max is each ray's nearest hit so far */
    int8 id;                    /* closest hit: the nearest hit's primitive id, -1 before any (the
                                   query kernels report t and id only) */
    uint live;                  /* any-hit: the rays not yet blocked */
    uint8 visits;               /* nodes (or primitives, COUNT_PRIM_TESTS) each ray was carried through */
    int sp;
    bool overflow;              /* the packet cannot finish (a full stack): walk the rays alone */
    uint stack_key[WIDE_STACK_SIZE + BVH_WIDTH];
    int stack_node[WIDE_STACK_SIZE + BVH_WIDTH];
    uchar stack_rays[WIDE_STACK_SIZE + BVH_WIDTH]; /* which rays hit the entry's box */
} Packet;

INLINE void count_visit(Packet *p, uint rays, int count) {
#if COUNT_PRIM_TESTS
    p->visits += as_uint8(ray_lanes(rays)) & (uint8)((uint)(count > 0 ? count : 0));
#else
    p->visits -= as_uint8(ray_lanes(rays)); /* lanes are -1 where set */
#endif
}

/* A node's boxes against the packet's rays in `rays`: the nearest entry distance over those rays per
 * lane (INF_T where none hits) and, per lane, the mask of rays that hit.  Ray k's test is hit_boxes'
 * for that ray, operation for operation; each ray's own t_max culls. */
INLINE lanes_f packet_boxes(const Packet *p, __global const WideNode *node, float8 t_max, uint rays,
                            lanes_u *hit_rays) {
    __global const lanes_f *b = node->bounds;
    lanes_f nx = b[p->bx], fx = b[1 - p->bx], ny = b[2 + p->by], fy = b[3 - p->by];
    lanes_f nz = b[4 + p->bz], fz = b[5 - p->bz];
    lanes_f nearest = (lanes_f)(INF_T);
    lanes_u hits = (lanes_u)(0u);
#define PACKET_BOX(k)                                                                                                 \
    if (rays & (1u << k)) {                                                                                           \
        lanes_f t_enter = (lanes_f)(0.0f), t_exit = (lanes_f)(t_max.s##k);                                            \
        slab_lanes(nx, fx, p->ox.s##k, p->ix.s##k, &t_enter, &t_exit);                                                \
        slab_lanes(ny, fy, p->oy.s##k, p->iy.s##k, &t_enter, &t_exit);                                                \
        slab_lanes(nz, fz, p->oz.s##k, p->iz.s##k, &t_enter, &t_exit);                                                \
        t_exit *= BOX_EXIT_WIDEN;                                                                                     \
        lanes_i hit = t_enter <= t_exit;                                                                              \
        nearest = (hit & (t_enter < nearest)) ? t_enter : nearest;                                                    \
        hits |= as_lanes_u(hit) & (lanes_u)(1u << k);                                                                 \
    }
    FOR_EACH_RAY(PACKET_BOX)
#undef PACKET_BOX
    *hit_rays = hits;
    return nearest;
}

/* Push a node's hit lanes as push_lanes does (sorted by their nearest ray's entry distance), each
 * with the rays that hit it. */
INLINE void packet_push(Packet *p, int node, lanes_f nearest, lanes_u hit_rays, bool farthest_first) {
    lanes_u keys = lane_keys(nearest, farthest_first);
    int n = hit_count(keys != (lanes_u)(0u));
    if (n == 0) return;
    if (p->sp + n > WIDE_STACK_SIZE) { p->overflow = true; return; }
    uint r[BVH_WIDTH] = LANES_ARRAY(hit_rays);
    int sp = p->sp;
    if (n == 1) {
        uint key = max_key(keys);
        p->stack_key[sp] = key; p->stack_node[sp] = node; p->stack_rays[sp] = (uchar)r[key_lane(key, farthest_first)];
    } else {
        keys = sort_keys_decreasing(keys);
        uint k[BVH_WIDTH] = LANES_ARRAY(keys);
        for (int j = 0; j < BVH_WIDTH; ++j) {
            p->stack_key[sp + j] = k[j]; p->stack_node[sp + j] = node;
            p->stack_rays[sp + j] = (uchar)r[key_lane(k[j], farthest_first)];
        }
    }
    p->sp = sp + n;
}

/* A node's boxes (`node`, at index `index` of its tree) against the packet's `rays` with their t_max, the lanes hit
 * pushed: the walker's push (kernels/packet_walks.h).  A full stack ends the walk. */
INLINE void packet_node(Packet *p, __global const WideNode *node, int index, float8 t_max, uint rays, bool farthest_first) {
    lanes_u hit_rays;
    lanes_f nearest = packet_boxes(p, node, t_max, rays, &hit_rays);
    packet_push(p, index, nearest, hit_rays, farthest_first);
    if (p->overflow) p->sp = 0;
}

/* One visit more for each ray in `rays`. */
INLINE void count_rays(uint *visits, uint rays) {
    for (int k = 0; k < PACKET_RAYS; ++k) visits[k] += (rays >> k) & 1u;
}

/* ---------------------------------------------------------------- instanced packets (the query kernels, -DINSTANCED=1)
 * Eight world rays whose directions share their signs walk the top tree together (packet_boxes on its wide
 * nodes, each ray's own t range); at an instance the rays that reached it go into object space as
 * visit_instance_entered takes them (the same float operations per ray) and walk its mesh as one packet
 * when they still go the same way there (a rotation can change the signs or the largest axis), else one by
 * one.  Each ray's answer is its one-ray walk's: every mesh walk keeps the nearest hit below the ray's
 * nearest so far (ties to the lower id), so the order instances are met in changes nothing. */
typedef struct {
    Ray r[PACKET_RAYS];                  /* world rays (make_box_ray's) */
    float t_min[PACKET_RAYS], t_max[PACKET_RAYS];
    Hit best[PACKET_RAYS];               /* closest hit: the nearest so far (slot 0 on an instance's hit: the
                                            query kernels read t, id and instance only) */
    float T[PACKET_RAYS];                /* any-hit: 0 once blocked */
    uint visits[PACKET_RAYS];
} InstanceRays;

/* A packet of the world rays for the top tree's box tests (packet_boxes reads origins, 1/d and the octant). */
INLINE void top_packet(Packet *p, const InstanceRays *q, uint rays) {
#define RAY_LANES(f) (float8)(q->r[0].f, q->r[1].f, q->r[2].f, q->r[3].f, q->r[4].f, q->r[5].f, q->r[6].f, q->r[7].f)
    p->ox = RAY_LANES(o.x); p->oy = RAY_LANES(o.y); p->oz = RAY_LANES(o.z);
    p->ix = RAY_LANES(inv_d.x); p->iy = RAY_LANES(inv_d.y); p->iz = RAY_LANES(inv_d.z);
#undef RAY_LANES
    p->bx = q->r[0].inv_d.x < 0.0f; p->by = q->r[0].inv_d.y < 0.0f; p->bz = q->r[0].inv_d.z < 0.0f;
    p->live = rays;
    p->visits = (uint8)(0u);
    p->sp = 0;
    p->overflow = false;
}

/* The packet's walks, once per kind (kernels/packet_walks.h): closest hit (the _closest functions) and any-hit
 * (_any). */
#define ANY_HIT 0
#define KIND(f) f##_closest
#include "packet_walks.h"
#define ANY_HIT 1
#define KIND(f) f##_any
#include "packet_walks.h"

#pragma OPENCL FP_CONTRACT ON

#endif
#endif
