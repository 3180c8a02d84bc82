/* Tracing kernels: whole-pixel rendering, and plain ray queries for the
 * Tracer API and the benchmarks.  Variants: -DUSE_BVH=0|1, -DMAX_DEPTH=n. */
/* A program holds the render kernel or the ray queries, never both: -DRENDER_BUILD=1 (clrender/trace/
 * variant.py, Variant.render) compiles `render` alone, -DRENDER_BUILD=0 the Tracer's queries and test
 * kernels.  Each compile is then a part of the work (the queries' packets and shafts, or the shading). */
#ifndef RENDER_BUILD
#error "RENDER_BUILD is missing: build trace.cl with clrender.trace.variant.Variant.defines()"
#endif
#include "common.h"
#include "rng.h"
#include "sampling.h"
#include "camera.h"
#include "intersect.h"
#include "tables.h"
#include "shade.h"
#include "packet.h"

/* The ray kernels below take RAYS_PER_ITEM consecutive rays per work-item (an incomplete last group
 * repeats the last ray): 8, a packet's worth, or 1 (the layout chosen per device, clrender/trace/
 * work_layout.py).  Eight through the wide trees go as one packet when they go the same way
 * (kernels/packet.h, -DRAY_PACKETS=1), else in pairs whose walks are stepped in turn (walk_pair);
 * one per item, and through the binary tree or without one, one by one (trace_query). */
#if RAYS_PER_ITEM != 8 && RAYS_PER_ITEM != 1
#error "RAYS_PER_ITEM must be 8 (a packet's worth of rays per work-item) or 1"
#endif
#define ITEM_PACKETS (USE_BVH && BVH_WIDTH >= 4 && RAYS_PER_ITEM == 8 && !INSTANCED) /* packets and pairs of walks */
/* instances: eight rays that go the same way walk the top tree and each mesh as packets (walk_instance_packet),
 * others one at a time (walk_instances) */
#define INSTANCE_PACKETS (USE_BVH && BVH_WIDTH >= 4 && RAYS_PER_ITEM == 8 && INSTANCED && RAY_PACKETS)

#if RENDER_BUILD
/* The pixels `pixels[0 .. frame.n_work)` of one launch (WhittedParams, clrender/layout.py): each pixel's
 * samples traced and filtered into out's colour region, their BVH visits and rays into its stats; with
 * frame.record, the first sample's ids, shadows (n_lights per pixel) and, with -DWRITE_AOV=1, AOVs.
 * The buffers: the Tracer's geometry (nodes, prims, prim_object, normals, attributes, texels) and its
 * scene tables, the renderer's world, and one launch's outputs, as arenas placed by the record's regions. */
__kernel void render(__global const TreeNode *nodes, __global const PrimSlot *prims, __global const int *prim_object,
                     __global const VertexNormals *normals, __global const VertexAttributes *attributes,
                     __global const float4 *texels, __global const char *tables, __global const char *world,
                     __global const int *pixels, WhittedParams params, __global char *out) {
    FrameParams frame = params.frame;
    int gid = get_global_id(0);
    if (gid >= frame.n_work) return;
    SceneView sc;
    sc.geo = scene_geometry(nodes, prims, prim_object, tables, frame.tables, frame.n_prims, frame.n_instances, true);
    sc.normals = normals; sc.lights = REGION(world, const Light, frame.world.lights);
    sc.tex = scene_textures(attributes, tables, frame.tables, texels);
    sc.n_lights = frame.n_lights; sc.light_samples = params.light_samples;
    sc.max_depth = frame.max_depth; sc.fresnel = params.fresnel; sc.light_stratified = params.light_stratified;
    sc.background = vload3(0, params.background); sc.ambient = vload3(0, params.ambient);
    /* escaping rays look the map up; nothing samples it */
    sc.env = env_view(frame.env_map, REGION(world, const float4, frame.world.env_texels), 0, 0);
    __global float4 *colour_out = REGION(out, float4, frame.out.colour);
    __global IdRecord *ids_out = REGION(out, IdRecord, frame.out.ids);
    __global float *shadow_out = REGION(out, float, frame.out.shadow);
    __global uint2 *stats_out = REGION(out, uint2, frame.out.stats);
    __global AovRecord *aov_out = REGION(out, AovRecord, frame.out.aov);
    int pixel = pixels[gid];
    uint n = (uint)frame.samples_per_side;
    float3 sum = (float3)(0.0f);
    float weight_sum = 0.0f;
    uint visits = 0, rays = 0;
    for (uint s = 0; s < n * n; ++s) {
        Rng rng = make_rng(frame.seed, (uint)pixel, s);
        PixelSample ps = pixel_sample(&frame, pixel, frame.sampler, s, n, &rng);
        bool keep = frame.record && s == 0; /* ids and shadows of the first sample */
#if WRITE_AOV
        sc.aov = keep ? aov_out + gid : 0; /* AOVs come from the same ray as the ids */
#endif
        sum += ps.weight * trace_path(&sc, ps.ray, &rng, keep ? ids_out + gid : 0,
                                      keep ? shadow_out + (size_t)gid * frame.n_lights : 0, &visits, &rays);
        weight_sum += ps.weight;
    }
    colour_out[gid] = (float4)(sum / weight_sum, 1.0f);
    stats_out[gid] = (uint2)(visits, rays);
}

#else /* the Tracer's build: ray queries, sample offsets and the test kernels */

/* Sample offsets in [0,1)^2 of pixel `pixels[i]`, for tests and plots. */
__kernel void sample_offsets(__global const int *pixels, int n_work, int sampler, int samples_per_side,
                             uint seed, __global float2 *out) {
    int gid = get_global_id(0);
    if (gid >= n_work) return;
    uint n = (uint)samples_per_side;
    for (uint s = 0; s < n * n; ++s) {
        Rng rng = make_rng(seed, (uint)pixels[gid], s);
        out[(size_t)gid * n * n + s] = pixel_sample_offset(sampler, s, n, &rng);
    }
}


/* Ray i of packed (x, y, z) float32 triples (the caller's arrays, uploaded as they are). */
INLINE float3 load_xyz(__global const float *xyz, int i) { return (float3)(xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2]); }

/* A query ray's units.  Distances are in units of the direction as given (Embree's convention);
 * the kernels trace the unit direction, and |d| = length / scale.  scale is 1 unless d's squared
 * length would over- or underflow float32 (components beyond ~1e19 or below ~1e-19); then it is the
 * power of two that brings d's largest component into [1, 2), and scaling by it is exact, so such
 * rays are traced as if float32 held |d| (instead of giving inf or NaN). */
typedef struct { float scale, unscale, length; } QueryUnits; /* unscale = 1 / scale */

INLINE float to_unit_t(float t, QueryUnits u) { return t * u.unscale * u.length; } /* t * |d| */
INLINE float to_query_t(float t, QueryUnits u) { return t / u.length * u.scale; }  /* t / |d| */

INLINE float3 query_direction(__global const float *directions, int i, QueryUnits *units) {
    float3 d = load_xyz(directions, i);
    float length_sq = dot3(d, d);
    units->scale = units->unscale = 1.0f;
    if (!(length_sq >= 0x1p-120f && length_sq <= 0x1p120f)) {
        float3 a = abs3(d);
        float largest = max3(a); /* > 0: the host refuses zero directions */
        int exponent = (int)((as_uint(largest) >> 23) & 0xffu) - 127;
        int power = -exponent < -126 ? -126 : (-exponent > 126 ? 126 : -exponent);
        units->scale = as_float((uint)(power + 127) << 23);    /* 2^power */
        units->unscale = as_float((uint)(127 - power) << 23);  /* 2^-power */
        d *= units->scale;
        length_sq = dot3(d, d);
    }
    units->length = sqrt(length_sq);
    return d / units->length;
}

/* The ray for box tests only (shear_ray before a triangle test: rays that miss every box never need it) */
INLINE Ray query_box_ray(__global const float *origins, __global const float *directions, int i, QueryUnits *units) {
    return make_box_ray(load_xyz(origins, i), query_direction(directions, i, units));
}

INLINE Ray query_ray(__global const float *origins, __global const float *directions, int i, QueryUnits *units) {
    Ray r = query_box_ray(origins, directions, i, units);
    shear_ray(&r);
    return r;
}

/* One work-item's rays: where they come from, and what their walks found. */
typedef struct {
    __global const float *origins, *directions; /* the caller's (x, y, z) triples */
    __global const float *t_min, *t_max;         /* per ray; t_max for any-hit only */
    int n;                                       /* rays of this item (fewer in the last one) */
    int idx[RAYS_PER_ITEM];                      /* their indices; past n, the last ray again */
    QueryUnits units[RAYS_PER_ITEM];
    Hit hit[RAYS_PER_ITEM];                      /* closest hit */
    float T[RAYS_PER_ITEM];                      /* any-hit: 0 where blocked */
    uint visits[RAYS_PER_ITEM];
} QueryItem;

INLINE void query_item(QueryItem *q, int first, int n_rays, __global const float *origins, __global const float *directions,
                       __global const float *t_min, __global const float *t_max) {
    q->origins = origins; q->directions = directions; q->t_min = t_min; q->t_max = t_max;
    q->n = min(n_rays - first, RAYS_PER_ITEM);
    for (int k = 0; k < RAYS_PER_ITEM; ++k) { q->idx[k] = min(first + k, n_rays - 1); q->visits[k] = 0; }
}

/* Ray k's segment in the units of its unit direction (t_max: INF_T for closest hits). */
INLINE float2 query_segment(const QueryItem *q, int k, bool any_hit) {
    int i = q->idx[k];
    return (float2)(to_unit_t(q->t_min[i], q->units[k]), to_unit_t(any_hit ? q->t_max[i] : INF_T, q->units[k]));
}

#if ITEM_PACKETS
/* Rays k and k + 1 walked in turn, closest hit or any-hit; the same ray for a wide walk has its shear
 * (six divisions) computed only once the root has a hit: most rays of a small mesh's batch miss it. */
INLINE void walk_pair(QueryItem *q, const Geometry *g, int k, bool any_hit) {
    Walk w[2];
    for (int j = 0; j < 2; ++j) {
        Ray r = query_box_ray(q->origins, q->directions, q->idx[k + j], &q->units[k + j]);
        float2 segment = query_segment(q, k + j, any_hit);
        query_walk_start(&w[j], g, r, segment.x, segment.y, any_hit);
        if (w[j].sp > 0) shear_ray(&w[j].r);
    }
    while (w[0].sp > 0 || w[1].sp > 0) {
        if (w[0].sp > 0) mesh_step(&w[0], g, opaque_pass(), any_hit);
        if (w[1].sp > 0) mesh_step(&w[1], g, opaque_pass(), any_hit);
    }
    for (int j = 0; j < 2; ++j) {
        mesh_finish(&w[j], g, opaque_pass(), any_hit, 1.0f);
        if (any_hit) q->T[k + j] = w[j].T;
        else q->hit[k + j] = w[j].best.slot < 0 ? no_hit() : w[j].best;
        q->visits[k + j] = w[j].visits;
    }
}

/* The eight rays as one packet: false (nothing written) when they do not go the same way or the
 * packet cannot finish, and the caller walks them in pairs. */
INLINE bool walk_packet(QueryItem *q, const Geometry *g, bool any_hit) {
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
        float2 segment = query_segment(q, k, any_hit);
        t0[k] = segment.x;
        t1[k] = segment.y;
    }
    Packet p;
    if (!packet_start(&p, g, r, t0, t1, any_hit)) return false;
    while (p.sp > 0) packet_step(&p, g, any_hit);
    if (p.fallback) return false;
    float t[PACKET_RAYS] = RAY_ARRAY(p.t_max);
    int id[PACKET_RAYS] = RAY_ARRAY(p.id);
    uint v[PACKET_RAYS] = RAY_ARRAY(p.visits);
    for (int k = 0; k < PACKET_RAYS; ++k) {
        if (any_hit) q->T[k] = (p.live >> k) & 1u ? 1.0f : 0.0f;
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
INLINE bool walk_instance_packet(QueryItem *q, const Geometry *g, bool any_hit) {
    uint3 signs = as_uint3(load_xyz(q->directions, q->idx[0])) >> 31;
    for (int k = 1; k < PACKET_RAYS; ++k) {
        uint3 s = as_uint3(load_xyz(q->directions, q->idx[k])) >> 31;
        if ((s.x != signs.x) | (s.y != signs.y) | (s.z != signs.z)) return false;
    }
    InstanceRays ir;
    uint rays = 0;
    for (int k = 0; k < PACKET_RAYS; ++k) {
        ir.r[k] = query_box_ray(q->origins, q->directions, q->idx[k], &q->units[k]);
        float2 segment = query_segment(q, k, any_hit);
        ir.t_min[k] = segment.x;
        ir.t_max[k] = segment.y;
        ir.best[k] = no_hit();
        ir.best[k].t = segment.y;
        ir.T[k] = 1.0f;
        ir.visits[k] = 0;
        if (g->n_prims > 0) {
            Ray r_flat = ir.r[k];
            shear_ray(&r_flat);
            walk_tree(g, r_flat, segment.x, segment.y, any_hit, opaque_pass(), &ir.best[k], &ir.T[k], &ir.visits[k]);
        }
        rays |= (any_hit && ir.T[k] == 0.0f) ? 0u : 1u << k;
    }
    if (g->n_instances > 0 && rays != 0 && !packet_top(g, &ir, rays, any_hit)) return false;
    for (int k = 0; k < PACKET_RAYS; ++k) {
        if (any_hit) q->T[k] = ir.T[k];
        else q->hit[k] = ir.best[k].slot < 0 ? no_hit() : ir.best[k];
        q->visits[k] = ir.visits[k];
    }
    return true;
}
#endif

/* Every ray of the item, closest hit (q->hit) or any-hit with opaque surfaces (q->T), and the nodes
 * each visited. */
INLINE void trace_item(QueryItem *q, const Geometry *g, bool any_hit) {
#if ITEM_PACKETS
    if (!walk_packet(q, g, any_hit))
        for (int k = 0; k < q->n; k += 2) walk_pair(q, g, k, any_hit);
#else
#if INSTANCE_PACKETS
    if (walk_instance_packet(q, g, any_hit)) return;
#endif
    for (int k = 0; k < q->n; ++k) {
#if INSTANCED
        Ray r = query_box_ray(q->origins, q->directions, q->idx[k], &q->units[k]); /* each walk shears its own */
#else
        Ray r = query_ray(q->origins, q->directions, q->idx[k], &q->units[k]);
#endif
        float2 segment = query_segment(q, k, any_hit);
        if (any_hit) q->T[k] = transmittance(g, r, segment.x, segment.y, opaque_pass(), &q->visits[k]);
        else q->hit[k] = closest_hit(g, r, segment.x, segment.y, &q->visits[k]);
    }
#endif
}

/* Closest hit of arbitrary rays: origins and directions as (x, y, z) triples, directions of any
 * nonzero length.  A hit is o + t d, t in (t_min, INF).  Writes t (INF on a miss), primitive id,
 * object id and the nodes visited. */
__kernel void intersect_rays(__global const TreeNode *nodes, __global const PrimSlot *prims,
                             __global const int *prim_object, __global const char *tables, QueryParams params,
                             __global const float *origins, __global const float *directions,
                             __global const float *t_min,
                             __global float *t_out, __global int *prim_out, __global int *object_out,
                             __global uint *visits_out) {
    int first = RAYS_PER_ITEM * get_global_id(0), n_rays = params.n_rays;
    if (first >= n_rays) return;
    Geometry g = scene_geometry(nodes, prims, prim_object, tables, params.tables, params.n_prims, params.n_instances, false);
    QueryItem q;
    query_item(&q, first, n_rays, origins, directions, t_min, 0);
    trace_item(&q, &g, false);
    for (int k = 0; k < q.n; ++k) {
        Hit h = q.hit[k];
        t_out[q.idx[k]] = to_query_t(h.t, q.units[k]);
        prim_out[q.idx[k]] = h.id;
        object_out[q.idx[k]] = hit_object(&g, h);
        visits_out[q.idx[k]] = q.visits[k];
    }
}

/* Any-hit occlusion: 1 when some surface lies at o + t d, t in (t_min, t_max), d as given. */
__kernel void occluded_rays(__global const TreeNode *nodes, __global const PrimSlot *prims,
                            __global const int *prim_object, __global const char *tables, QueryParams params,
                            __global const float *origins, __global const float *directions,
                            __global const float *t_min, __global const float *t_max,
                            __global int *occluded_out, __global uint *visits_out) {
    int first = RAYS_PER_ITEM * get_global_id(0), n_rays = params.n_rays;
    if (first >= n_rays) return;
    Geometry g = scene_geometry(nodes, prims, prim_object, tables, params.tables, params.n_prims, params.n_instances, true);
    QueryItem q;
    query_item(&q, first, n_rays, origins, directions, t_min, t_max);
    trace_item(&q, &g, true);
    for (int k = 0; k < q.n; ++k) {
        occluded_out[q.idx[k]] = q.T[k] == 0.0f;
        visits_out[q.idx[k]] = q.visits[k];
    }
}

/* Snell's law as the renderer applies it, for tests: (direction, 1) or (0, 0) on total internal reflection. */
__kernel void refract_rays(int n, __global const float4 *d, __global const float4 *normals, __global const float *eta,
                           __global float4 *out) {
    int gid = get_global_id(0);
    if (gid >= n) return;
    float3 t;
    int ok = refract_dir(unit(d[gid].xyz), unit(normals[gid].xyz), eta[gid], &t);
    out[gid] = ok ? (float4)(t, 1.0f) : (float4)(0.0f);
}

/* (n.h)^s as the shading computes it, for tests: out[i] = x[i]^s[i]. */
__kernel void specular_power(int n, __global const float *x, __global const float *s, __global float *out) {
    int gid = get_global_id(0);
    if (gid >= n) return;
    out[gid] = pow_unit(x[gid], s[gid]);
}
#endif
