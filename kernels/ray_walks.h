/* One ray's walks of one kind, included twice by kernels/intersect.h: ANY_HIT 0 (closest hit: the nearest hit in
 * *best) with KIND(f) naming f_closest, ANY_HIT 1 (any-hit: the light let through in *T) with KIND(f) naming f_any.
 * Each kind is its own functions, so no walk takes its kind as a runtime flag.  ANY_HIT and KIND are undefined at
 * the end.  The leaf hooks (leaf slots and blocks, instances), the walker (kernels/walk.h) on a mesh's tree and on
 * the instances' top tree, and the entry point trace_query. */

/* One leaf of slots [begin, end), or every slot.  Closest hit: the nearest hit is kept in *best, and
 * of hits at the same t the lower primitive id, so every traversal order (BVH on or off, binary or
 * wide, either builder) finds the same primitive.  Any-hit: *T is multiplied by each slot's
 * crossing_transmittance, in slot order, until it is 0. */
INLINE void KIND(leaf_slots)(const Geometry *g, int begin, int end, Ray r, float t_min, float t_max, Pass pass,
                             Hit *best, float *T) {
    for (int s = begin; s < end && (!ANY_HIT || *T > 0.0f); ++s) {
        if (ANY_HIT) {
            *T *= crossing_transmittance(g, s, r, t_min, t_max, pass);
            continue;
        }
        float u = 0.0f, v = 0.0f;
        float t = hit_slot(g, s, r, t_min, best->t * HIT_TIE_WIDEN, &u, &v);
        int id = prim_slot(g, s)->id;
        if (t != INF_T && nearer_hit(t, id, best)) {
            best->t = t; best->slot = s; best->id = id; best->u = u; best->v = v;
        }
    }
}

#if BVH_WIDTH >= 4
/* The blocks of a wide leaf of `count` primitives from block `first` on (leaf_block), the triangles of a
 * block tested at once, its sphere lanes (rare: a sphere is one primitive) one by one by leaf_slots.
 * Closest hit: as leaf_slots.  Any-hit: the leaf's own product of crossings, which then multiplies *T
 * (the grouping the renders were made with: float products are not associative). */
INLINE void KIND(leaf_blocks)(const Geometry *g, int first, int count, Ray r, float t_min, float t_max, Pass pass,
                              Hit *best, float *T) {
    __global const LeafBlock *block = leaf_block(g, first);
    float leaf_T = 1.0f;
    for (int b = 0; b < count && leaf_T > 0.0f; b += BLOCK_LANES, ++block) {
        int4 slot = block->slot;
        float4 u, v;
        float4 t = hit_block(r, block, slot >= 0, t_min, ANY_HIT ? t_max : best->t * HIT_TIE_WIDEN, &u, &v);
        if (!ANY_HIT) {
            nearest_lane(g, slot, t, u, v, best);
        } else if (pass.opaque) {
            int4 crossed = t != (float4)(INF_T);
            if (crossed.x | crossed.y | crossed.z | crossed.w) { *T = 0.0f; return; } /* blocked */
        } else {
            leaf_T = times_crossed(g, pass, block, t, leaf_T);
        }
        if (slot.x < -1 || slot.y < -1 || slot.z < -1 || slot.w < -1) { /* spheres: -2 - slot */
            int sl[4] = {slot.x, slot.y, slot.z, slot.w};
            for (int k = 0; k < BLOCK_LANES; ++k)
                if (sl[k] < -1) KIND(leaf_slots)(g, -2 - sl[k], -1 - sl[k], r, t_min, t_max, pass, best, &leaf_T);
        }
    }
    if (ANY_HIT) *T *= leaf_T;
}
#endif

/* ---------------------------------------------------------------- the walker on a mesh's tree (kernels/walk.h)
 * Its leaf hook: a wide leaf's blocks (leaf_blocks), a binary leaf's slots (leaf_slots); after a stack filled up,
 * every slot (trees are at most clrender.trace.bvh.MAX_TREE_LEVELS deep and the stacks hold them, so only smaller
 * knobs reach it: the tests of the fallback; the answer is the same). */
INLINE void KIND(mesh_leaf)(const Geometry *g, int first, int count, bool own_box, Ray r, float t_min, float t_max,
                            Pass pass, Hit *best, float *T, uint *visits) {
    COUNT_PRIMS(visits, count); /* any-hit: at most, it stops at the first opaque hit */
#if BVH_WIDTH >= 4
    KIND(leaf_blocks)(g, first, count, r, t_min, t_max, pass, best, T);
#else
    KIND(leaf_slots)(g, first, first + count, r, t_min, t_max, pass, best, T);
#endif
}

INLINE void KIND(mesh_every)(const Geometry *g, Ray r, float t_min, float t_max, Pass pass, Hit *best, float *T,
                             uint *visits) {
    KIND(leaf_slots)(g, 0, g->n_prims, r, t_min, t_max, pass, best, T);
}

#if USE_BVH
#define walk_root KIND(mesh_root)
#define walk_step KIND(mesh_step)
#define walk_start KIND(mesh_start)
#define walk_finish KIND(mesh_finish)
#define walk_wide KIND(mesh_walk)
#define walk_binary KIND(mesh_walk)
#define WALK_ANY ANY_HIT
#define WALK_WIDE (BVH_WIDTH >= 4)
#define WALK_NODES(g) ((g)->nodes)
#define WALK_ROOT(g) ((g)->n_prims > 0)
#define WALK_RAY_LEAF KIND(mesh_leaf)
#define WALK_EVERY KIND(mesh_every)
#define WALK_SORT_ANY 0 /* any-hit: the far child first (binary trees) */
#include "walk.h"
#endif

#if USE_BVH && BVH_WIDTH >= 4
/* A query kernel's walk (walk_group in query_walks.h: rays that did not form a packet, mostly incoherent): every node's
 * keys sorted (push_lanes' sort_always), stepped by mesh_step, ended by mesh_finish(..., 1.0f). */
INLINE void KIND(query_walk_start)(Walk *w, const Geometry *g, Ray r, float t_min, float t_max) {
    Hit best = no_hit();
    best.t = t_max;
    KIND(mesh_start)(w, g, r, t_min, t_max, &best, 1.0f, true);
}
#endif

/* Every traversal's entry point: the closest hit in (t_min, t_max) in *best (slot -1 on a miss), or
 * (any-hit) the light let through up to t_max in *T, through the tree the build chose (USE_BVH,
 * BVH_WIDTH) or, without one, every primitive.  r is sheared.  *visits grows by the nodes visited
 * (see COUNT_NODE). */
INLINE void KIND(walk_tree)(const Geometry *g, Ray r, float t_min, float t_max, Pass pass, Hit *best, float *T,
                            uint *visits) {
    *best = no_hit();
    best->t = t_max;
    *T = 1.0f;
#if USE_BVH
    KIND(mesh_walk)(g, r, t_min, t_max, pass, false, false, best, T, visits); /* renders: mostly coherent rays */
#else
    KIND(leaf_slots)(g, 0, g->n_prims, r, t_min, t_max, pass, best, T);
    *visits += (uint)g->n_prims;
#endif
}

#if INSTANCED
/* ---------------------------------------------------------------- instances (intersect.h, "instances")
 * The mesh tree of an instance, for a ray already in object space: the wide walk, its shear (three
 * divisions) made only once the root has a hit (as the query kernels' walk_group), else walk_tree. */
INLINE void KIND(walk_mesh)(const Geometry *s, Ray r, float t_min, float t_max, Pass pass, Hit *best, float *T,
                            uint *visits) {
#if USE_BVH && BVH_WIDTH >= 4
    *best = no_hit();
    best->t = t_max;
    *T = 1.0f;
    KIND(mesh_walk)(s, r, t_min, t_max, pass, INSTANCE_SORT_ALWAYS, true, best, T, visits);
#else
    shear_ray(&r);
    KIND(walk_tree)(s, r, t_min, t_max, pass, best, T, visits);
#endif
}

/* Instance i met in object space, its world box entered.  Closest hit: its mesh's hit (local id +
 * prim_base, ties to the lower id as everywhere) replaces *best when nearer; any-hit: *T times its
 * transmittance (transparency_of reads the instance's object: s.object). */
INLINE void KIND(visit_instance_entered)(const Geometry *g, int i, Ray r, float t_min, float t_max, Pass pass,
                                         Hit *best, float *T, uint *visits) {
    __global const Instance *in = g->instances + i;
    float t_far = ANY_HIT ? t_max : best->t;
    Ray r_object = make_box_ray(affine_point(&in->world_to_object[0][0], r.o), affine_vector(&in->world_to_object[0][0], r.d));
    Geometry s = instance_geometry(g, in);
    Hit h;
    float T_in;
    KIND(walk_mesh)(&s, r_object, t_min, t_far, pass, &h, &T_in, visits);
    if (ANY_HIT) { *T *= T_in; return; }
    int id = h.id + in->prim_base;
    if (h.slot >= 0 && nearer_hit(h.t, id, best)) {
        *best = h; best->id = id; best->instance = i;
    }
}

/* Instance i, if the ray enters its world box before the nearest hit so far. */
INLINE void KIND(visit_instance)(const Geometry *g, int i, Ray r, float t_min, float t_max, Pass pass, Hit *best,
                                 float *T, uint *visits) {
    __global const Instance *in = g->instances + i;
    float t_far = ANY_HIT ? t_max : best->t;
    if (hit_bounds(r, in->bmin, in->bmax, t_far) == INF_T) return;
    KIND(visit_instance_entered)(g, i, r, t_min, t_max, pass, best, T, visits);
}

/* ---------------------------------------------------------------- the walker on the top tree (kernels/walk.h)
 * Its leaf hook: a leaf's instances by visit_instance (a wide leaf lane of one instance: its box is the instance's
 * own, visit_instance_entered); after a stack filled up (never with the builder's depth limit), every instance, the
 * nearest hit whatever the order, any-hit again from the flat part's T. */
INLINE void KIND(top_leaf)(const Geometry *g, int first, int count, bool own_box, Ray r, float t_min, float t_max,
                           Pass pass, Hit *best, float *T, uint *visits) {
    if (own_box && count == 1) {
        KIND(visit_instance_entered)(g, first, r, t_min, t_max, pass, best, T, visits);
        return;
    }
    for (int i = first; i < first + count && !(ANY_HIT && *T == 0.0f); ++i)
        KIND(visit_instance)(g, i, r, t_min, t_max, pass, best, T, visits);
}

INLINE void KIND(top_every)(const Geometry *g, Ray r, float t_min, float t_max, Pass pass, Hit *best, float *T,
                            uint *visits) {
    KIND(top_leaf)(g, 0, g->n_instances, false, r, t_min, t_max, pass, best, T, visits);
}

/* -DTOP_WIDE=1: the top tree in wide nodes (the instances' boxes tested eight at once), else binary; a closest hit
 * drops a box entered beyond the nearest hit so far (the flat part's to start with) */
#define walk_root KIND(top_root)
#define walk_step KIND(top_step)
#define walk_start KIND(top_start)
#define walk_finish KIND(top_finish)
#define walk_wide KIND(top_walk)
#define walk_binary KIND(top_walk)
#define WALK_ANY ANY_HIT
#define WALK_WIDE TOP_WIDE
#define WALK_NODES(g) ((g)->top)
#define WALK_ROOT(g) ((g)->n_instances > 0)
#define WALK_RAY_LEAF KIND(top_leaf)
#define WALK_EVERY KIND(top_every)
#define WALK_SORT_ANY 1 /* any-hit: the nearer child first too (binary top trees) */
#include "walk.h"

/* The flat part (when it has primitives), then the top tree (top_walk), each leaf's instances by visit_instance.
 * r needs no shear: each walk makes its own. */
INLINE void KIND(walk_instances)(const Geometry *g, Ray r, float t_min, float t_max, Pass pass, Hit *best, float *T,
                                 uint *visits) {
    *best = no_hit();
    best->t = t_max;
    *T = 1.0f;
    if (g->n_prims > 0) {
        Ray r_flat = r;
        shear_ray(&r_flat);
        KIND(walk_tree)(g, r_flat, t_min, t_max, pass, best, T, visits);
    }
    if (g->n_instances == 0 || (ANY_HIT && *T == 0.0f)) return;
    KIND(top_walk)(g, r, t_min, t_max, pass, false, false, best, T, visits);
}

/* Every query's entry point (closest_hit, transmittance, the query kernels): the closest hit in (t_min, t_max) in
 * *best (slot -1 on a miss), or the light let through up to t_max in *T; instanced, walk_instances (r sheared or
 * not: each walk shears its own), else walk_tree (r sheared). */
INLINE void KIND(trace_query)(const Geometry *g, Ray r, float t_min, float t_max, Pass pass, Hit *best, float *T,
                              uint *visits) {
    KIND(walk_instances)(g, r, t_min, t_max, pass, best, T, visits);
}
#else
INLINE void KIND(trace_query)(const Geometry *g, Ray r, float t_min, float t_max, Pass pass, Hit *best, float *T,
                              uint *visits) {
    KIND(walk_tree)(g, r, t_min, t_max, pass, best, T, visits);
}
#endif

#undef ANY_HIT
#undef KIND
