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
 * are tested ray by ray with the lone walk's test. */
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
    bool fallback;              /* the packet cannot finish (a full stack): walk the rays alone */
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
    if (p->sp + n > WIDE_STACK_SIZE) { p->fallback = true; return; }
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

/* Eight rays (make_box_ray's: not yet sheared) whose directions have the same signs (the caller checks
 * them, walk_packet in trace.cl, before it builds the rays) as a packet of the rays in `rays` (the others'
 * lanes copy one of those: packet_instance), or false if their largest axes differ.  They are sheared (shear_ray) only once the root has a hit: most packets of a small
 * mesh miss it. */
INLINE bool packet_start_rays(Packet *p, const Geometry *g, Ray *r, const float *t_min, const float *t_max, uint rays,
                              bool any_hit) {
#define LANES(f) (float8)(r[0].f, r[1].f, r[2].f, r[3].f, r[4].f, r[5].f, r[6].f, r[7].f)
    p->ox = LANES(o.x); p->oy = LANES(o.y); p->oz = LANES(o.z);
    p->dx = LANES(d.x); p->dy = LANES(d.y); p->dz = LANES(d.z);
    p->ix = LANES(inv_d.x); p->iy = LANES(inv_d.y); p->iz = LANES(inv_d.z);
    p->bx = r[0].inv_d.x < 0.0f; p->by = r[0].inv_d.y < 0.0f; p->bz = r[0].inv_d.z < 0.0f;
    p->t_min = (float8)(t_min[0], t_min[1], t_min[2], t_min[3], t_min[4], t_min[5], t_min[6], t_min[7]);
    p->t_max = (float8)(t_max[0], t_max[1], t_max[2], t_max[3], t_max[4], t_max[5], t_max[6], t_max[7]);
    p->id = (int8)(-1);
    p->live = rays;
    p->visits = (uint8)(0u);
    p->sp = 0;
    p->fallback = false;
    if (g->n_prims > 0) {
        count_visit(p, rays, 0);
        lanes_u hit_rays;
        lanes_f nearest = packet_boxes(p, g->nodes, p->t_max, rays, &hit_rays);
        packet_push(p, 0, nearest, hit_rays, any_hit);
    }
    if (p->sp == 0) return true; /* every ray misses the root: no triangle test, no shear */
    for (int k = 0; k < PACKET_RAYS; ++k) {
        shear_ray(&r[k]);
        if (r[k].kz != r[0].kz) return false;
    }
    p->sx = LANES(sx); p->sy = LANES(sy); p->sz = LANES(sz);
#undef LANES
    p->kx = r[0].kx; p->ky = r[0].ky; p->kz = r[0].kz;
    float8 o[3] = {p->ox, p->oy, p->oz};
    p->okx = o[p->kx]; p->oky = o[p->ky]; p->okz = o[p->kz];
    return true;
}

/* All eight rays as a packet (the query kernels' walk_packet). */
INLINE bool packet_start(Packet *p, const Geometry *g, Ray *r, const float *t_min, const float *t_max, bool any_hit) {
    return packet_start_rays(p, g, r, t_min, t_max, ALL_RAYS, any_hit);
}

/* Sphere slot s against the packet's `rays`, one ray at a time (a sphere is a whole leaf lane, and
 * rare): the lone walk's tests, leaf_slots' (closest hit) or crossing_transmittance's (any-hit). */
INLINE void packet_sphere(Packet *p, const Geometry *g, int s, uint rays, bool any_hit) {
    float ox[PACKET_RAYS] = RAY_ARRAY(p->ox), oy[PACKET_RAYS] = RAY_ARRAY(p->oy), oz[PACKET_RAYS] = RAY_ARRAY(p->oz);
    float dx[PACKET_RAYS] = RAY_ARRAY(p->dx), dy[PACKET_RAYS] = RAY_ARRAY(p->dy), dz[PACKET_RAYS] = RAY_ARRAY(p->dz);
    float t_min[PACKET_RAYS] = RAY_ARRAY(p->t_min), t_max[PACKET_RAYS] = RAY_ARRAY(p->t_max);
    int best_id[PACKET_RAYS] = RAY_ARRAY(p->id);
    int id = prim_slot(g, s)->id;
    for (int k = 0; k < PACKET_RAYS; ++k) {
        if (((rays >> k) & 1u) == 0) continue;
        Ray r = make_box_ray((float3)(ox[k], oy[k], oz[k]), (float3)(dx[k], dy[k], dz[k]));
        int8 lane = ray_lanes(1u << k);
        if (any_hit) {
            if (crossing_transmittance(g, s, r, t_min[k], t_max[k], opaque_pass()) == 0.0f) p->live &= ~(1u << k);
        } else {
            float u, v, t = hit_slot(g, s, r, t_min[k], t_max[k] * HIT_TIE_WIDEN, &u, &v);
            if (t < t_max[k] || (t == t_max[k] && t != INF_T && id < best_id[k])) {
                p->t_max = lane ? (float8)(t) : p->t_max;
                p->id = lane ? (int8)(id) : p->id;
            }
        }
    }
}

/* The triangles of a leaf's blocks against the packet's `rays`, one triangle at a time: closest hit
 * keeps each ray's nearest (ties to the lower id, as nearest_lane), any-hit (opaque) drops the rays
 * that are blocked from p->live.  Spheres go ray by ray (packet_sphere). */
INLINE void packet_leaf(Packet *p, const Geometry *g, int first, int count, uint rays, bool any_hit) {
    __global const LeafBlock *block = leaf_block(g, first);
    for (int b = 0; b < count; b += BLOCK_LANES, ++block) {
        int4 slot4 = block->slot;
        int slots[BLOCK_LANES] = {slot4.x, slot4.y, slot4.z, slot4.w};
        for (int k = 0; k < BLOCK_LANES; ++k) {
            int slot = slots[k];
            if (slot == -1) continue; /* an empty lane */
            if (slot < -1) { /* a sphere: slot -2 - s */
                packet_sphere(p, g, -2 - slot, rays, any_hit);
                if (any_hit && (rays &= p->live) == 0) return;
                continue;
            }
            /* lane k of vertex n's coordinates along `axis` */
#define VERTEX(n, axis) LANE_OF(float, block->v##n[axis], k)
            float8 t_range = any_hit ? p->t_max : p->t_max * HIT_TIE_WIDEN, u, v;
            float8 t = triangle_test8(VERTEX(0, p->kx) - p->okx, VERTEX(0, p->ky) - p->oky, VERTEX(0, p->kz) - p->okz,
                                      VERTEX(1, p->kx) - p->okx, VERTEX(1, p->ky) - p->oky, VERTEX(1, p->kz) - p->okz,
                                      VERTEX(2, p->kx) - p->okx, VERTEX(2, p->ky) - p->oky, VERTEX(2, p->kz) - p->okz,
                                      ray_lanes(rays), p->sx, p->sy, p->sz, p->t_min, t_range, &u, &v);
#undef VERTEX
            int8 hit = t != (float8)(INF_T);
            if (!any8(hit)) continue;
            if (any_hit) {
                p->live &= ~ray_bits(hit);
                rays &= p->live;
                if (rays == 0) return;
            } else {
                int8 id = (int8)(prim_slot(g, slot)->id);
                int8 nearer = hit & ((t < p->t_max) | ((t == p->t_max) & (id < p->id)));
                p->t_max = nearer ? t : p->t_max;
                p->id = nearer ? id : p->id;
            }
        }
    }
}

/* Visit the entry on top of the stack with the rays that hit its box and may still need it. */
INLINE void packet_step(Packet *p, const Geometry *g, bool any_hit) {
    int sp = --p->sp;
    uint key = p->stack_key[sp];
    uint rays = p->stack_rays[sp];
    /* closest hit: a ray whose nearest hit is nearer than every ray's entry into the box is done with it */
    rays &= any_hit ? p->live : ray_bits((float8)(key_t(key)) <= p->t_max * BOX_EXIT_WIDEN);
    if (rays == 0) return;
    __global const WideNode *node = g->nodes + p->stack_node[sp];
    int lane = key_lane(key, any_hit);
    int child = LANE_OF(int, node->child, lane), count = LANE_OF(int, node->count, lane);
    if (count < 0) return; /* an empty lane (see walk.h's step) */
    count_visit(p, rays, count);
    if (count > 0) {
        packet_leaf(p, g, child, count, rays, any_hit);
        if (any_hit && p->live == 0) p->sp = 0;
    } else {
        lanes_u hit_rays;
        lanes_f nearest = packet_boxes(p, g->nodes + child, p->t_max, rays, &hit_rays);
        packet_push(p, child, nearest, hit_rays, any_hit);
        if (p->fallback) p->sp = 0;
    }
}


#if INSTANCED
/* ---------------------------------------------------------------- instanced packets (the query kernels)
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

/* Each ray's nearest hit so far (closest hit) or its segment's end (any-hit), in lanes. */
INLINE float8 instance_rays_far(const InstanceRays *q, bool any_hit) {
    float f[PACKET_RAYS];
    for (int k = 0; k < PACKET_RAYS; ++k) f[k] = any_hit ? q->t_max[k] : q->best[k].t;
    return (float8)(f[0], f[1], f[2], f[3], f[4], f[5], f[6], f[7]);
}

/* The rays not yet blocked (any-hit), or all (closest hit). */
INLINE uint instance_rays_live(const InstanceRays *q, bool any_hit) {
    uint live = 0;
    for (int k = 0; k < PACKET_RAYS; ++k) live |= (!any_hit || q->T[k] != 0.0f) ? 1u << k : 0u;
    return live;
}

/* The mesh packet's answers merged into each ray's, as visit_instance_entered merges a walk's. */
INLINE void merge_instance_packet(InstanceRays *q, const Packet *p, int i, int prim_base, uint rays, bool any_hit) {
    float t[PACKET_RAYS] = RAY_ARRAY(p->t_max);
    int id[PACKET_RAYS] = RAY_ARRAY(p->id);
    uint v[PACKET_RAYS] = RAY_ARRAY(p->visits);
    for (int k = 0; k < PACKET_RAYS; ++k) {
        if (((rays >> k) & 1u) == 0) continue;
        q->visits[k] += v[k];
        if (any_hit) {
            if (((p->live >> k) & 1u) == 0) q->T[k] *= 0.0f; /* the one-ray walk's *T *= T_in, T_in 0 */
        } else if (id[k] >= 0) {
            int hit_id = id[k] + prim_base;
            Hit *b = &q->best[k];
            if (nearer_hit(t[k], hit_id, b)) {
                b->t = t[k]; b->slot = 0; b->id = hit_id; b->u = 0.0f; b->v = 0.0f; b->instance = i;
            }
        }
    }
}

/* Instance i for the rays in `rays` (which entered its world box): in object space, one packet when their
 * directions there share signs and largest axis and its stack does not fill, else visit_instance_entered each. */
INLINE void packet_instance(const Geometry *g, int i, InstanceRays *q, uint rays, bool any_hit) {
    __global const Instance *in = g->instances + i;
    __global const float *m = &in->world_to_object[0][0];
    Geometry s = instance_geometry(g, in);
    Ray r[PACKET_RAYS];
    float t0[PACKET_RAYS], t1[PACKET_RAYS];
    int first = 31 - (int)clz(rays & (~rays + 1u)); /* the lowest ray in `rays`: the other lanes copy it */
    uint3 signs = (uint3)(0u);
    bool same = true;
    for (int k = 0; k < PACKET_RAYS; ++k) {
        int j = ((rays >> k) & 1u) ? k : first;
        r[k] = make_box_ray(affine_point(m, q->r[j].o), affine_vector(m, q->r[j].d));
        t0[k] = q->t_min[j];
        t1[k] = any_hit ? q->t_max[j] : q->best[j].t;
        uint3 sk = as_uint3(r[k].d) >> 31;
        if (k == 0) signs = sk;
        same &= (sk.x == signs.x) & (sk.y == signs.y) & (sk.z == signs.z);
    }
    if (same) {
        Packet p;
        if (packet_start_rays(&p, &s, r, t0, t1, rays, any_hit)) {
            while (p.sp > 0) packet_step(&p, &s, any_hit);
            if (!p.fallback) { merge_instance_packet(q, &p, i, in->prim_base, rays, any_hit); return; }
        }
    }
    for (int k = 0; k < PACKET_RAYS; ++k)
        if ((rays >> k) & 1u)
            visit_instance_entered(g, i, q->r[k], q->t_min[k], q->t_max[k], any_hit, opaque_pass(), &q->best[k], &q->T[k],
                                   &q->visits[k]);
}

/* Instances [first, first + count) of a top leaf for the rays in `rays`: with `own_box` (a wide leaf lane of
 * one instance) the rays that hit the lane's box, its own; else each ray's box test of each instance
 * (visit_instance's). */
INLINE void packet_top_leaf(const Geometry *g, int first, int count, bool own_box, InstanceRays *q, uint rays,
                            bool any_hit) {
    for (int i = first; i < first + count; ++i) {
        uint in_rays = rays & instance_rays_live(q, any_hit);
        if (!own_box) {
            __global const Instance *in = g->instances + i;
            for (int k = 0; k < PACKET_RAYS; ++k)
                if (((in_rays >> k) & 1u) &&
                    hit_bounds(q->r[k], in->bmin, in->bmax, any_hit ? q->t_max[k] : q->best[k].t) == INF_T)
                    in_rays &= ~(1u << k);
        }
        if (in_rays != 0) packet_instance(g, i, q, in_rays, any_hit);
    }
}

/* A packet of the world rays for the top tree's box tests (packet_boxes reads origins, 1/d and the octant). */
INLINE void top_packet(Packet *p, const InstanceRays *q, uint rays) {
#define LANES(f) (float8)(q->r[0].f, q->r[1].f, q->r[2].f, q->r[3].f, q->r[4].f, q->r[5].f, q->r[6].f, q->r[7].f)
    p->ox = LANES(o.x); p->oy = LANES(o.y); p->oz = LANES(o.z);
    p->ix = LANES(inv_d.x); p->iy = LANES(inv_d.y); p->iz = LANES(inv_d.z);
#undef LANES
    p->bx = q->r[0].inv_d.x < 0.0f; p->by = q->r[0].inv_d.y < 0.0f; p->bz = q->r[0].inv_d.z < 0.0f;
    p->live = rays;
    p->visits = (uint8)(0u);
    p->sp = 0;
    p->fallback = false;
}

#if TOP_WIDE
/* The top tree with the rays in `rays` (the top walk's order, by the packet's nearest ray): false when its
 * stack fills up (the caller walks the rays one by one). */
INLINE bool packet_top(const Geometry *g, InstanceRays *q, uint rays, bool any_hit) {
    Packet p;
    top_packet(&p, q, rays);
    lanes_u hit_rays;
    lanes_f nearest = packet_boxes(&p, g->top, instance_rays_far(q, any_hit), rays, &hit_rays);
    packet_push(&p, 0, nearest, hit_rays, any_hit);
    for (int k = 0; k < PACKET_RAYS; ++k) q->visits[k] += (rays >> k) & 1u;
    while (p.sp > 0 && !p.fallback) {
        int sp = --p.sp;
        uint key = p.stack_key[sp];
        float8 t_far = instance_rays_far(q, any_hit);
        uint live = instance_rays_live(q, any_hit);
        uint in_rays = p.stack_rays[sp] & live & (any_hit ? ALL_RAYS : ray_bits((float8)(key_t(key)) <= t_far * BOX_EXIT_WIDEN));
        if (in_rays == 0) continue;
        __global const WideNode *node = g->top + p.stack_node[sp];
        int lane = key_lane(key, any_hit);
        int child = LANE_OF(int, node->child, lane), count = LANE_OF(int, node->count, lane);
        if (count < 0) continue; /* an empty lane */
        for (int k = 0; k < PACKET_RAYS; ++k) q->visits[k] += (in_rays >> k) & 1u;
        if (count > 0) {
            packet_top_leaf(g, child, count, count == 1, q, in_rays, any_hit);
        } else {
            nearest = packet_boxes(&p, g->top + child, t_far, in_rays, &hit_rays);
            packet_push(&p, child, nearest, hit_rays, any_hit);
        }
    }
    return !p.fallback;
}
#else
/* The binary top tree when it is one leaf (two instances; a binary top of more nodes: false, one by one). */
INLINE bool packet_top(const Geometry *g, InstanceRays *q, uint rays, bool any_hit) {
    __global const BvhNode *root = g->top;
    if (root->count <= 0) return false;
    for (int k = 0; k < PACKET_RAYS; ++k)
        if (((rays >> k) & 1u) && hit_bounds(q->r[k], root->bmin, root->bmax, any_hit ? q->t_max[k] : q->best[k].t) == INF_T)
            rays &= ~(1u << k);
    for (int k = 0; k < PACKET_RAYS; ++k) q->visits[k] += (rays >> k) & 1u;
    if (rays != 0) packet_top_leaf(g, root->offset, root->count, false, q, rays, any_hit);
    return true;
}
#endif
#endif
#pragma OPENCL FP_CONTRACT ON

#endif
#endif
