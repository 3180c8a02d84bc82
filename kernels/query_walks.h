/* The query kernels' walks of one kind, included twice by kernels/trace.cl as kernels/ray_walks.h is by
 * intersect.h: ANY_HIT 0 (intersect_rays: each ray's closest hit in q->hit) with KIND(f) naming f_closest, ANY_HIT 1
 * (occluded_rays: 0 in q->T where blocked) with KIND(f) naming f_any; both undefined at the end.  A work-item's
 * rays as one packet (kernels/packet.h), as groups of QUERY_WALKS walks stepped in turn, or one at a time. */

/* Ray k's segment in the units of its unit direction (t_max: INF_T for closest hits). */
INLINE float2 KIND(query_segment)(const QueryItem *q, int k) {
    int i = q->idx[k];
    return (float2)(to_unit_t(q->t_min[i], q->units[k]), to_unit_t(ANY_HIT ? q->t_max[i] : INF_T, q->units[k]));
}

#if ITEM_PACKETS
/* Rays k .. k + QUERY_WALKS - 1 walked in turn, one step each a round: their steps do not depend on each other, so
 * the CPU overlaps one walk's load and branch latencies with the others' work (docs/bvh.md, "Traversal").  A wide
 * walk's ray has its shear (six divisions) computed only once the root has a hit: most rays of a small mesh's batch
 * miss it. */
INLINE void KIND(walk_group)(QueryItem *q, const Geometry *g, int k) {
    Walk w[QUERY_WALKS];
    for (int j = 0; j < QUERY_WALKS; ++j) {
        Ray r = query_box_ray(q->origins, q->directions, q->idx[k + j], &q->units[k + j]);
        float2 segment = KIND(query_segment)(q, k + j);
        KIND(query_walk_start)(&w[j], g, r, segment.x, segment.y);
        if (w[j].sp > 0) shear_ray(&w[j].r);
    }
    for (bool stepped = true; stepped;) {
        stepped = false;
        for (int j = 0; j < QUERY_WALKS; ++j)
            if (w[j].sp > 0) { KIND(mesh_step)(&w[j], g, opaque_pass()); stepped = true; }
    }
    for (int j = 0; j < QUERY_WALKS; ++j) {
        KIND(mesh_finish)(&w[j], g, opaque_pass(), 1.0f);
        if (ANY_HIT) q->T[k + j] = w[j].T;
        else q->hit[k + j] = w[j].best.slot < 0 ? no_hit() : w[j].best;
        q->visits[k + j] = w[j].visits;
    }
}

/* The eight rays as one packet: false (nothing written) when they do not go the same way or the
 * packet cannot finish, and the caller walks them in groups (walk_group). */
INLINE bool KIND(walk_packet)(QueryItem *q, const Geometry *g) {
#if RAY_PACKETS
    /* the signs first (as 1/d will have them, -0 included): most incoherent groups stop here */
    uint3 signs = as_uint3(load_xyz(q->directions, q->idx[0])) >> 31;
    for (int k = 1; k < PACKET_RAYS; ++k) {
        uint3 s = as_uint3(load_xyz(q->directions, q->idx[k])) >> 31;
        if ((s.x != signs.x) | (s.y != signs.y) | (s.z != signs.z)) return false;
    }
    Ray r[PACKET_RAYS];
    float t0[PACKET_RAYS], t1[PACKET_RAYS];
    for (int k = 0; k < PACKET_RAYS; ++k) {
        r[k] = query_box_ray(q->origins, q->directions, q->idx[k], &q->units[k]);
        float2 segment = KIND(query_segment)(q, k);
        t0[k] = segment.x;
        t1[k] = segment.y;
    }
    Packet p;
    if (!KIND(packet_walk)(&p, g, r, t0, t1, ALL_RAYS)) return false;
    float t[PACKET_RAYS] = RAY_ARRAY(p.t_max);
    int id[PACKET_RAYS] = RAY_ARRAY(p.id);
    uint v[PACKET_RAYS] = RAY_ARRAY(p.visits);
    for (int k = 0; k < PACKET_RAYS; ++k) {
        if (ANY_HIT) q->T[k] = (p.live >> k) & 1u ? 1.0f : 0.0f;
        else { q->hit[k] = no_hit(); if (id[k] >= 0) { q->hit[k].t = t[k]; q->hit[k].id = id[k]; } }
        q->visits[k] = v[k];
    }
    return true;
#else
    return false;
#endif
}
#endif

#if INSTANCE_PACKETS
/* The eight rays with instances (packet.h, "instanced packets"): the flat part ray by ray as walk_instances
 * walks it, then the top tree and the meshes as packets.  False (nothing written) when their directions
 * differ in sign or the top tree's stack fills up, and the caller walks them one by one. */
INLINE bool KIND(walk_instance_packet)(QueryItem *q, const Geometry *g) {
    uint3 signs = as_uint3(load_xyz(q->directions, q->idx[0])) >> 31;
    for (int k = 1; k < PACKET_RAYS; ++k) {
        uint3 s = as_uint3(load_xyz(q->directions, q->idx[k])) >> 31;
        if ((s.x != signs.x) | (s.y != signs.y) | (s.z != signs.z)) return false;
    }
    InstanceRays ir;
    uint rays = 0;
    for (int k = 0; k < PACKET_RAYS; ++k) {
        ir.r[k] = query_box_ray(q->origins, q->directions, q->idx[k], &q->units[k]);
        float2 segment = KIND(query_segment)(q, k);
        ir.t_min[k] = segment.x;
        ir.t_max[k] = segment.y;
        ir.best[k] = no_hit();
        ir.best[k].t = segment.y;
        ir.T[k] = 1.0f;
        ir.visits[k] = 0;
        if (g->n_prims > 0) {
            Ray r_flat = ir.r[k];
            shear_ray(&r_flat);
            KIND(walk_tree)(g, r_flat, segment.x, segment.y, opaque_pass(), &ir.best[k], &ir.T[k], &ir.visits[k]);
        }
        rays |= (ANY_HIT && ir.T[k] == 0.0f) ? 0u : 1u << k;
    }
    if (g->n_instances > 0 && rays != 0 && !KIND(packet_top)(g, &ir, rays)) return false;
    for (int k = 0; k < PACKET_RAYS; ++k) {
        if (ANY_HIT) q->T[k] = ir.T[k];
        else q->hit[k] = ir.best[k].slot < 0 ? no_hit() : ir.best[k];
        q->visits[k] = ir.visits[k];
    }
    return true;
}
#endif

/* Every ray of the item, closest hit (q->hit) or any-hit with opaque surfaces (q->T), and the nodes
 * each visited. */
INLINE void KIND(trace_item)(QueryItem *q, const Geometry *g) {
#if ITEM_PACKETS
    if (!KIND(walk_packet)(q, g))
        for (int k = 0; k < q->n; k += QUERY_WALKS) KIND(walk_group)(q, g, k);
#else
#if INSTANCE_PACKETS
    if (KIND(walk_instance_packet)(q, g)) return;
#endif
    for (int k = 0; k < q->n; ++k) {
#if INSTANCED
        Ray r = query_box_ray(q->origins, q->directions, q->idx[k], &q->units[k]); /* each walk shears its own */
#else
        Ray r = query_ray(q->origins, q->directions, q->idx[k], &q->units[k]);
#endif
        float2 segment = KIND(query_segment)(q, k);
        Hit best;
        float T;
        KIND(trace_query)(g, r, segment.x, segment.y, opaque_pass(), &best, &T, &q->visits[k]);
        if (ANY_HIT) q->T[k] = T;
        else q->hit[k] = best.slot < 0 ? no_hit() : best;
    }
#endif
}

#undef ANY_HIT
#undef KIND
