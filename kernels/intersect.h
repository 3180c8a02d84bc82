/* Ray-primitive tests and BVH traversal (closest hit and shadow transmittance). */
#ifndef CLRENDER_INTERSECT_H
#define CLRENDER_INTERSECT_H

#include "common.h"

typedef struct {
    float t;       /* distance along the (unit) direction; INF_T on a miss */
    int slot;      /* index into prims; -1 on a miss */
    int id;        /* primitive id in scene order; -1 on a miss */
    float u, v;    /* barycentrics of v1 and v2 on a triangle */
} Hit;

inline Hit no_hit(void) {
    Hit h;
    h.t = INF_T; h.slot = -1; h.id = -1; h.u = 0.0f; h.v = 0.0f;
    return h;
}

inline bool is_sphere(__global const float4 *prims, int slot) { return prims[3 * slot + 1].w != 0.0f; }

inline int prim_id(__global const float4 *prims, int slot) { return as_int(prims[3 * slot].w); }

/* Moller-Trumbore, in scalars (float3 arithmetic costs shuffles on CPUs).
 * Returns t in (t_min, t_max) or INF_T; degenerate triangles never hit. */
inline float hit_triangle(Ray r, float4 v0, float4 e1, float4 e2, float t_min, float t_max, float *u, float *v) {
    float px = r.d.y * e2.z - r.d.z * e2.y, py = r.d.z * e2.x - r.d.x * e2.z, pz = r.d.x * e2.y - r.d.y * e2.x;
    float det = e1.x * px + e1.y * py + e1.z * pz;
    if (det == 0.0f) return INF_T; /* parallel to the plane, or a degenerate triangle */
    float inv_det = 1.0f / det;
    float tx = r.o.x - v0.x, ty = r.o.y - v0.y, tz = r.o.z - v0.z;
    /* Barycentric bounds are widened by EDGE_EPS so that rounding never opens
     * a crack along an edge two triangles share (ties go to the lower id). */
    const float EDGE_EPS = 1e-6f;
    float uu = (tx * px + ty * py + tz * pz) * inv_det;
    if (uu < -EDGE_EPS || uu > 1.0f + EDGE_EPS) return INF_T;
    float qx = ty * e1.z - tz * e1.y, qy = tz * e1.x - tx * e1.z, qz = tx * e1.y - ty * e1.x;
    float vv = (r.d.x * qx + r.d.y * qy + r.d.z * qz) * inv_det;
    if (vv < -EDGE_EPS || uu + vv > 1.0f + EDGE_EPS) return INF_T;
    float t = (e2.x * qx + e2.y * qy + e2.z * qz) * inv_det;
    if (!(t > t_min && t < t_max)) return INF_T;
    *u = uu; *v = vv;
    return t;
}

/* Both roots of |o + t d - c|^2 = r^2 for unit d, in the cancellation-free
 * form (Ray Tracing Gems ch. 7): the discriminant from the ray's closest
 * approach, the small root from c/q. */
inline int sphere_roots(Ray r, float4 cr, float *t0, float *t1) {
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

inline float hit_sphere(Ray r, float4 cr, float t_min, float t_max) {
    float t0, t1;
    if (!sphere_roots(r, cr, &t0, &t1)) return INF_T;
    if (t0 > t_min && t0 < t_max) return t0;
    if (t1 > t_min && t1 < t_max) return t1;
    return INF_T;
}

/* Distance to primitive slot s in (t_min, t_max), or INF_T; u, v set on a triangle hit. */
inline float hit_slot(__global const float4 *prims, int s, Ray r, float t_min, float t_max, float *u, float *v) {
    float4 a = prims[3 * s], b = prims[3 * s + 1], c = prims[3 * s + 2];
    if (b.w != 0.0f) return hit_sphere(r, (float4)(a.xyz, b.x), t_min, t_max);
    return hit_triangle(r, a, b, c, t_min, t_max, u, v);
}

/* One slab of the box test: the entry and exit distances (lo - o) / d and
 * (hi - o) / d, picked by the sign of 1/d (so -0 counts as negative).  The
 * form (b - o) * inv_d is inf, never inf - inf, when d is zero and o lies off
 * the slab's planes; it is NaN only when 0 * inf, i.e. d is zero and o lies
 * exactly on a plane: the ray runs inside the closed slab, and the caller's
 * max_f/min_f chains drop a NaN, so that axis then bounds nothing. */
inline void slab(float lo, float hi, float o, float inv_d, float *t_enter, float *t_exit) {
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
inline float hit_box(Ray r, float4 bmin, float4 bmax, float t_max) {
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
inline void test_slots(__global const float4 *prims, int begin, int end, Ray r, float t_min, Hit *best) {
    for (int s = begin; s < end; ++s) {
        float u = 0.0f, v = 0.0f;
        float t = hit_slot(prims, s, r, t_min, best->t * 1.0000002f, &u, &v);
        int id = as_int(prims[3 * s].w);
        if (t < best->t || (t == best->t && t != INF_T && id < best->id)) {
            best->t = t; best->slot = s; best->id = id; best->u = u; best->v = v;
        }
    }
}

inline Hit closest_hit(__global const float4 *nodes, __global const float4 *prims, int n_prims,
                       Ray r, float t_min, float t_max, uint *visits) {
    Hit best = no_hit();
    best.t = t_max;
#if USE_BVH
    int stack[STACK_SIZE];
    float stack_t[STACK_SIZE];
    int sp = 0;
    int node = (n_prims > 0 && hit_box(r, nodes[0], nodes[1], best.t) != INF_T) ? 0 : -1;
    while (node >= 0) {
        *visits += 1;
        float4 lo = nodes[2 * node], hi = nodes[2 * node + 1];
        int count = as_int(hi.w), offset = as_int(lo.w);
        int next = -1;
        if (count > 0) {
            test_slots(prims, offset, offset + count, r, t_min, &best);
        } else {
            int near_child = node + 1, far_child = offset;
            float t_near = hit_box(r, nodes[2 * near_child], nodes[2 * near_child + 1], best.t);
            float t_far = hit_box(r, nodes[2 * far_child], nodes[2 * far_child + 1], best.t);
            if (t_far < t_near) { /* visit the nearer box first */
                int tmp = near_child; near_child = far_child; far_child = tmp;
                float tt = t_near; t_near = t_far; t_far = tt;
            }
            if (t_near != INF_T) {
                next = near_child;
                if (t_far != INF_T && sp < STACK_SIZE) { /* put far node on the stack */
                    stack[sp] = far_child; stack_t[sp] = t_far; ++sp;
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
#else
    test_slots(prims, 0, n_prims, r, t_min, &best);
    *visits += (uint)n_prims;
#endif
    if (best.slot < 0) best = no_hit();
    return best;
}

/* Fraction of light reaching t_max along the ray: 0 past an opaque surface,
 * times `transparency` for every crossing of a transparent one (the shadow
 * ray is not bent).  Stops as soon as an opaque surface is found.  With
 * opaque_only every surface blocks (a plain any-hit occlusion query). */
inline float crossing_transmittance(__global const float4 *prims, __global const int *prim_object,
                                    __global const int2 *objects, __global const float4 *materials,
                                    int s, Ray r, float t_min, float t_max, bool opaque_only) {
    float4 a = prims[3 * s], b = prims[3 * s + 1], c = prims[3 * s + 2];
    int crossings = 0;
    if (b.w != 0.0f) {
        float t0, t1;
        if (sphere_roots(r, (float4)(a.xyz, b.x), &t0, &t1)) {
            crossings = (t0 > t_min && t0 < t_max) + (t1 > t_min && t1 < t_max);
        }
    } else {
        float u, v;
        crossings = hit_triangle(r, a, b, c, t_min, t_max, &u, &v) != INF_T;
    }
    if (crossings == 0) return 1.0f;
    if (opaque_only) return 0.0f;
    int material = objects[prim_object[as_int(a.w)]].x;
    float transparency = materials[3 * material + 2].x;
    return crossings == 2 ? transparency * transparency : transparency;
}

inline float transmittance(__global const float4 *nodes, __global const float4 *prims, int n_prims,
                           __global const int *prim_object, __global const int2 *objects,
                           __global const float4 *materials, Ray r, float t_max, bool opaque_only,
                           uint *visits) {
    const float t_min = 0.0f;
    float T = 1.0f;
#if USE_BVH
    int stack[STACK_SIZE];
    int sp = 0;
    if (n_prims > 0 && hit_box(r, nodes[0], nodes[1], t_max) != INF_T) stack[sp++] = 0;
    while (sp > 0 && T > 0.0f) {
        int node = stack[--sp];
        *visits += 1;
        float4 lo = nodes[2 * node], hi = nodes[2 * node + 1];
        int count = as_int(hi.w), offset = as_int(lo.w);
        if (count > 0) {
            for (int s = offset; s < offset + count && T > 0.0f; ++s)
                T *= crossing_transmittance(prims, prim_object, objects, materials, s, r, t_min, t_max, opaque_only);
        } else {
            int children[2] = {node + 1, offset};
            for (int k = 0; k < 2; ++k) {
                int child = children[k];
                if (sp < STACK_SIZE && hit_box(r, nodes[2 * child], nodes[2 * child + 1], t_max) != INF_T)
                    stack[sp++] = child;
            }
        }
    }
#else
    for (int s = 0; s < n_prims && T > 0.0f; ++s)
        T *= crossing_transmittance(prims, prim_object, objects, materials, s, r, t_min, t_max, opaque_only);
    *visits += (uint)n_prims;
#endif
    return T;
}

#endif
