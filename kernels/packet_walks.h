/* The packets' walks of one kind, included twice by kernels/packet.h as kernels/ray_walks.h is by intersect.h:
 * ANY_HIT 0 (closest hit: each ray's nearest hit in p->t_max and p->id) with KIND(f) naming f_closest, ANY_HIT 1
 * (any-hit, opaque: the rays not blocked in p->live) with KIND(f) naming f_any; both undefined at the end.  The
 * leaf hooks, the walker (kernels/walk.h) with a Packet as its state on a mesh's tree and on the instances' top
 * tree, and their starts. */

/* Sphere slot s against the packet's `rays`, one ray at a time (a sphere is a whole leaf lane, and
 * rare): the lone walk's tests, leaf_slots' (closest hit) or crossing_transmittance's (any-hit). */
INLINE void KIND(packet_sphere)(Packet *p, const Geometry *g, int s, uint rays) {
    float ox[PACKET_RAYS] = RAY_ARRAY(p->ox), oy[PACKET_RAYS] = RAY_ARRAY(p->oy), oz[PACKET_RAYS] = RAY_ARRAY(p->oz);
    float dx[PACKET_RAYS] = RAY_ARRAY(p->dx), dy[PACKET_RAYS] = RAY_ARRAY(p->dy), dz[PACKET_RAYS] = RAY_ARRAY(p->dz);
    float t_min[PACKET_RAYS] = RAY_ARRAY(p->t_min), t_max[PACKET_RAYS] = RAY_ARRAY(p->t_max);
    int best_id[PACKET_RAYS] = RAY_ARRAY(p->id);
    int id = prim_slot(g, s)->id;
    for (int k = 0; k < PACKET_RAYS; ++k) {
        if (((rays >> k) & 1u) == 0) continue;
        Ray r = make_box_ray((float3)(ox[k], oy[k], oz[k]), (float3)(dx[k], dy[k], dz[k]));
        int8 lane = ray_lanes(1u << k);
        if (ANY_HIT) {
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
INLINE void KIND(packet_leaf)(Packet *p, const Geometry *g, int first, int count, uint rays) {
    __global const LeafBlock *block = leaf_block(g, first);
    for (int b = 0; b < count; b += BLOCK_LANES, ++block) {
        int4 slot4 = block->slot;
        int slots[BLOCK_LANES] = {slot4.x, slot4.y, slot4.z, slot4.w};
        for (int k = 0; k < BLOCK_LANES; ++k) {
            int slot = slots[k];
            if (slot == -1) continue; /* an empty lane */
            if (slot < -1) { /* a sphere: slot -2 - s */
                KIND(packet_sphere)(p, g, -2 - slot, rays);
                if (ANY_HIT && (rays &= p->live) == 0) return;
                continue;
            }
            /* lane k of vertex n's coordinates along `axis` */
#define VERTEX(n, axis) LANE_OF(float, block->v##n[axis], k)
            float8 t_range = ANY_HIT ? p->t_max : p->t_max * HIT_TIE_WIDEN, u, v;
            float8 t = triangle_test8(VERTEX(0, p->kx) - p->okx, VERTEX(0, p->ky) - p->oky, VERTEX(0, p->kz) - p->okz,
                                      VERTEX(1, p->kx) - p->okx, VERTEX(1, p->ky) - p->oky, VERTEX(1, p->kz) - p->okz,
                                      VERTEX(2, p->kx) - p->okx, VERTEX(2, p->ky) - p->oky, VERTEX(2, p->kz) - p->okz,
                                      ray_lanes(rays), p->sx, p->sy, p->sz, p->t_min, t_range, &u, &v);
#undef VERTEX
            int8 hit = t != (float8)(INF_T);
            if (!any8(hit)) continue;
            if (ANY_HIT) {
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

/* The walker with a Packet on a mesh's wide tree (packet_root, packet_step): an entry's rays are those that hit
 * its box and may still need it (packet_entry); a full stack ends the walk (p->overflow: the caller walks the rays
 * alone).  The context is unused: packets answer opaque queries only. */
/* The rays of stack entry sp that still need it (closest hit: a ray whose nearest hit is nearer than every ray's
 * entry into the box is done with it; any-hit: the rays not blocked). */
INLINE uint KIND(packet_entry)(const Packet *p, int sp, uint key) {
    uint rays = p->stack_rays[sp];
    return rays & (ANY_HIT ? p->live : ray_bits((float8)(key_t(key)) <= p->t_max * BOX_EXIT_WIDEN));
}

#define walk_root KIND(packet_root)
#define walk_step KIND(packet_step)
#define WALK_ANY ANY_HIT
#define WALK_WIDE 1
#define WALK_NODES(g) ((g)->nodes)
#define WALK_ROOT(g) ((g)->n_prims > 0)
#define WALK_STATE Packet
#define WALK_CONTEXT Pass
#define WALK_ENTRY(p, c, sp, key) KIND(packet_entry)(p, sp, key)
#define WALK_VISIT(p, c, rays, count) count_visit(p, rays, count)
#define WALK_PUSH(p, g, c, node, rays, size) packet_node(p, (g)->nodes + (node), node, (p)->t_max, rays, ANY_HIT)
#define WALK_LEAF(p, g, c, first, count, rays) KIND(packet_leaf)(p, g, first, count, rays)
#define WALK_DONE(p, c) (ANY_HIT && (p)->live == 0)
#include "walk.h"

/* Eight rays (make_box_ray's: not yet sheared) whose directions have the same signs (the caller checks
 * them, walk_packet in trace.cl, before it builds the rays) as a packet of the rays in `rays` (the others'
 * lanes copy one of those: packet_instance), or false if their largest axes differ.  They are sheared
 * (shear_ray) only once the root has a hit: most packets of a small mesh miss it. */
INLINE bool KIND(packet_start_rays)(Packet *p, const Geometry *g, Ray *r, const float *t_min, const float *t_max,
                                    uint rays) {
#define RAY_LANES(f) (float8)(r[0].f, r[1].f, r[2].f, r[3].f, r[4].f, r[5].f, r[6].f, r[7].f)
    p->ox = RAY_LANES(o.x); p->oy = RAY_LANES(o.y); p->oz = RAY_LANES(o.z);
    p->dx = RAY_LANES(d.x); p->dy = RAY_LANES(d.y); p->dz = RAY_LANES(d.z);
    p->ix = RAY_LANES(inv_d.x); p->iy = RAY_LANES(inv_d.y); p->iz = RAY_LANES(inv_d.z);
    p->bx = r[0].inv_d.x < 0.0f; p->by = r[0].inv_d.y < 0.0f; p->bz = r[0].inv_d.z < 0.0f;
    p->t_min = (float8)(t_min[0], t_min[1], t_min[2], t_min[3], t_min[4], t_min[5], t_min[6], t_min[7]);
    p->t_max = (float8)(t_max[0], t_max[1], t_max[2], t_max[3], t_max[4], t_max[5], t_max[6], t_max[7]);
    p->id = (int8)(-1);
    p->live = rays;
    p->visits = (uint8)(0u);
    p->sp = 0;
    p->overflow = false;
    KIND(packet_root)(p, g, opaque_pass(), rays);
    if (p->sp == 0) return true; /* every ray misses the root: no triangle test, no shear */
    for (int k = 0; k < PACKET_RAYS; ++k) {
        shear_ray(&r[k]);
        if (r[k].kz != r[0].kz) return false;
    }
    p->sx = RAY_LANES(sx); p->sy = RAY_LANES(sy); p->sz = RAY_LANES(sz);
#undef RAY_LANES
    p->kx = r[0].kx; p->ky = r[0].ky; p->kz = r[0].kz;
    float8 o[3] = {p->ox, p->oy, p->oz};
    p->okx = o[p->kx]; p->oky = o[p->ky]; p->okz = o[p->kz];
    return true;
}

/* A packet of rays in `rays` walked to the end (true), or false (nothing to use) when their largest axes differ or
 * the stack filled up: the caller walks them alone. */
INLINE bool KIND(packet_walk)(Packet *p, const Geometry *g, Ray *r, const float *t_min, const float *t_max, uint rays) {
    if (!KIND(packet_start_rays)(p, g, r, t_min, t_max, rays)) return false;
    while (p->sp > 0) KIND(packet_step)(p, g, opaque_pass());
    return !p->overflow;
}

#if INSTANCED
/* ---------------------------------------------------------------- instanced packets (packet.h, InstanceRays) */
/* Each ray's nearest hit so far (closest hit) or its segment's end (any-hit), in lanes. */
INLINE float8 KIND(instance_rays_far)(const InstanceRays *q) {
    float f[PACKET_RAYS];
    for (int k = 0; k < PACKET_RAYS; ++k) f[k] = ANY_HIT ? q->t_max[k] : q->best[k].t;
    return (float8)(f[0], f[1], f[2], f[3], f[4], f[5], f[6], f[7]);
}

/* The rays not yet blocked (any-hit), or all (closest hit). */
INLINE uint KIND(instance_rays_live)(const InstanceRays *q) {
    uint live = 0;
    for (int k = 0; k < PACKET_RAYS; ++k) live |= (!ANY_HIT || q->T[k] != 0.0f) ? 1u << k : 0u;
    return live;
}

/* The mesh packet's answers merged into each ray's, as visit_instance_entered merges a walk's. */
INLINE void KIND(merge_instance_packet)(InstanceRays *q, const Packet *p, int i, int prim_base, uint rays) {
    float t[PACKET_RAYS] = RAY_ARRAY(p->t_max);
    int id[PACKET_RAYS] = RAY_ARRAY(p->id);
    uint v[PACKET_RAYS] = RAY_ARRAY(p->visits);
    for (int k = 0; k < PACKET_RAYS; ++k) {
        if (((rays >> k) & 1u) == 0) continue;
        q->visits[k] += v[k];
        if (ANY_HIT) {
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
INLINE void KIND(packet_instance)(const Geometry *g, int i, InstanceRays *q, uint rays) {
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
        t1[k] = ANY_HIT ? q->t_max[j] : q->best[j].t;
        uint3 sk = as_uint3(r[k].d) >> 31;
        if (k == 0) signs = sk;
        same &= (sk.x == signs.x) & (sk.y == signs.y) & (sk.z == signs.z);
    }
    Packet p;
    if (same && KIND(packet_walk)(&p, &s, r, t0, t1, rays)) {
        KIND(merge_instance_packet)(q, &p, i, in->prim_base, rays);
        return;
    }
    for (int k = 0; k < PACKET_RAYS; ++k)
        if ((rays >> k) & 1u)
            KIND(visit_instance_entered)(g, i, q->r[k], q->t_min[k], q->t_max[k], opaque_pass(), &q->best[k], &q->T[k],
                                         &q->visits[k]);
}

/* Instances [first, first + count) of a top leaf for the rays in `rays`: with `own_box` (a wide leaf lane of
 * one instance) the rays that hit the lane's box, its own; else each ray's box test of each instance
 * (visit_instance's). */
INLINE void KIND(packet_top_leaf)(const Geometry *g, int first, int count, bool own_box, InstanceRays *q, uint rays) {
    for (int i = first; i < first + count; ++i) {
        uint in_rays = rays & KIND(instance_rays_live)(q);
        if (!own_box) {
            __global const Instance *in = g->instances + i;
            for (int k = 0; k < PACKET_RAYS; ++k)
                if (((in_rays >> k) & 1u) &&
                    hit_bounds(q->r[k], in->bmin, in->bmax, ANY_HIT ? q->t_max[k] : q->best[k].t) == INF_T)
                    in_rays &= ~(1u << k);
        }
        if (in_rays != 0) KIND(packet_instance)(g, i, q, in_rays);
    }
}

#if TOP_WIDE
/* The walker with a Packet of the world rays (top_packet) on the top tree (packet_top_root, packet_top_step):
 * each ray's answer so far is in the context (InstanceRays), which its box tests and culls read; a wide leaf
 * lane is one instance's own box. */
/* The rays of a top tree's stack entry sp that still need it, as packet_entry with each ray's answer so far in q. */
INLINE uint KIND(packet_top_entry)(const Packet *p, const InstanceRays *q, int sp, uint key) {
    uint rays = p->stack_rays[sp] & KIND(instance_rays_live)(q);
    return rays & (ANY_HIT ? ALL_RAYS : ray_bits((float8)(key_t(key)) <= KIND(instance_rays_far)(q) * BOX_EXIT_WIDEN));
}

#define walk_root KIND(packet_top_root)
#define walk_step KIND(packet_top_step)
#define WALK_ANY ANY_HIT
#define WALK_WIDE 1
#define WALK_NODES(g) ((g)->top)
#define WALK_ROOT(g) ((g)->n_instances > 0)
#define WALK_STATE Packet
#define WALK_CONTEXT InstanceRays *
#define WALK_ENTRY(p, q, sp, key) KIND(packet_top_entry)(p, q, sp, key)
#define WALK_VISIT(p, q, rays, count) count_rays((q)->visits, rays)
#define WALK_PUSH(p, g, q, node, rays, size) packet_node(p, (g)->top + (node), node, KIND(instance_rays_far)(q), rays, ANY_HIT)
#define WALK_LEAF(p, g, q, first, count, rays) KIND(packet_top_leaf)(g, first, count, (count) == 1, q, rays)
#define WALK_DONE(p, q) (ANY_HIT && KIND(instance_rays_live)(q) == 0)
#include "walk.h"

/* The top tree with the rays in `rays` (the top walk's order, by the packet's nearest ray): false when its
 * stack fills up (the caller walks the rays one by one). */
INLINE bool KIND(packet_top)(const Geometry *g, InstanceRays *q, uint rays) {
    Packet p;
    top_packet(&p, q, rays);
    KIND(packet_top_root)(&p, g, q, rays);
    while (p.sp > 0) KIND(packet_top_step)(&p, g, q);
    return !p.overflow;
}
#else
/* The binary top tree when it is one leaf (two instances; a binary top of more nodes: false, one by one). */
INLINE bool KIND(packet_top)(const Geometry *g, InstanceRays *q, uint rays) {
    __global const BvhNode *root = g->top;
    if (root->count <= 0) return false;
    for (int k = 0; k < PACKET_RAYS; ++k)
        if (((rays >> k) & 1u) && hit_bounds(q->r[k], root->bmin, root->bmax, ANY_HIT ? q->t_max[k] : q->best[k].t) == INF_T)
            rays &= ~(1u << k);
    count_rays(q->visits, rays);
    if (rays != 0) KIND(packet_top_leaf)(g, root->offset, root->count, false, q, rays);
    return true;
}
#endif
#endif

#undef ANY_HIT
#undef KIND
