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
 * (kernels/packet.h, -DRAY_PACKETS=1), else in groups of QUERY_WALKS whose walks are stepped in turn (walk_group);
 * one per item, and through the binary tree or without one, one by one (trace_query). */
#if RAYS_PER_ITEM != 8 && RAYS_PER_ITEM != 1
#error "RAYS_PER_ITEM must be 8 (a packet's worth of rays per work-item) or 1"
#endif
#define ITEM_PACKETS (USE_BVH && BVH_WIDTH >= 4 && RAYS_PER_ITEM == 8 && !INSTANCED) /* packets and groups of walks */
/* walks a work-item steps in turn: four, 6% more incoherent rays a second than two, and eight fewer (docs/bvh.md) */
#define QUERY_WALKS 4
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
    sc.env = env_view(frame.env_map, REGION(world, const float4, frame.world.env_texels), 0, 0, 0);
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
        sum += ps.weight * trace_path(&sc, make_ray(ps.o, ps.d), &rng, keep ? ids_out + gid : 0,
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

/* The work-item's walks, once per kind (kernels/query_walks.h): closest hit (trace_item_closest) and any-hit
 * (trace_item_any). */
#define ANY_HIT 0
#define KIND(f) f##_closest
#include "query_walks.h"
#define ANY_HIT 1
#define KIND(f) f##_any
#include "query_walks.h"

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
    trace_item_closest(&q, &g);
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
    trace_item_any(&q, &g);
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

#ifndef LANES
#error "a header undefined LANES (kernels/lanes.h): the lane-generic code after it took its lane branches"
#endif
