/* Whitted shading: ambient + Lambert + Blinn-Phong from point, directional
 * and parallelogram area lights with shadow rays, then mirror reflection and
 * refraction (Snell's law, total internal reflection, optional Schlick
 * Fresnel) on an explicit ray stack instead of recursion.
 *
 * Records (clrender/layout.py): Light, VertexNormals, Material, ObjectRecord,
 * IdRecord and AovRecord, read and written by field name.
 *
 * FP_CONTRACT is on here (intersect.h and shaft.h turn it back on after their
 * own code), so a*b + c may become one fma: an expression must keep its shape
 * for its value to keep its bits, and each lane function below is written with
 * the same expressions as its one-value form. */
#ifndef CLRENDER_SHADE_H
#define CLRENDER_SHADE_H

#include "common.h"
#include "intersect.h"
#include "sampling.h"
#include "shaft.h"
#include "envmap.h"
#include "texture.h"
#include "surface.h"
/* ALPHA_TEST: alpha-tested materials (glTF MASK, BLEND) */
#include "alpha.h"
#include "spot.h"

#ifndef WRITE_AOV
#define WRITE_AOV 0 /* 1: the render kernel also writes the primary hit's AOVs (renderer.py, --aov) */
#endif

/* What the render kernel shades with (the Python side's clrender.scene.Scene, packed). */
typedef struct {
    Geometry geo;
    __global const VertexNormals *normals; /* per primitive id */
    TextureView tex;                       /* uvs, vertex colours and textures (texture.h) */
    __global const Light *lights;
    int n_lights;
    int light_samples;   /* > 0 overrides every area light's samples per side */
    int max_depth;       /* bounces after the primary hit */
    int fresnel;         /* 0: transparency splits by its fixed fraction; 1: Schlick */
    int light_stratified; /* 1: one jittered sample per cell of an area light; 0: uniform random */
    float3 background;
    float3 ambient;
    EnvView env;         /* env.m.width > 0: rays that meet nothing see this map instead of the background */
#if WRITE_AOV
    __global AovRecord *aov; /* null, or this pixel's primary-hit record */
#endif
} SceneView;

/* A point being shaded: where it is, which way it faces, what it is made of. */
typedef struct {
    float3 p, p_err;  /* the hit point from the primitive, and its float32 error per axis */
    float3 n, n_geo;  /* unit shading and geometric normals, both on the side the ray came from */
    float3 v;         /* unit direction towards the viewer */
    float3 kd, ks;    /* the material's diffuse and specular colours */
    float shininess;  /* its Blinn-Phong exponent */
    int slot;         /* the primitive's slot: a shadow shaft leaves its own surface out */
    float3 origin_front, origin_back; /* where shadow rays leave, off the surface on the side they go (direct_light) */
} ShadingPoint;

#define MAX_FALLOFF 1e10f /* cap of 1/r^2 (r = 1e-5) and of an area light's A cos / r^2 */
#define INV_PI 0.318309886f /* 1/pi, of the physical BRDF */
#define MIN_N_DOT_H 1e-30f /* (n.h)^s is taken of n.h clamped to this: pow_unit needs x in (0, 1] */

INLINE float3 reflect_dir(float3 d, float3 n) { return d - 2.0f * dot3(d, n) * n; }

/* Snell's law for unit d and unit n facing against d, eta = n1 / n2.
 * Returns 0 when the ray cannot refract (total internal reflection). */
INLINE int refract_dir(float3 d, float3 n, float eta, float3 *out) {
    float cos_i = -dot3(d, n);
    float sin2_t = eta * eta * max_f(0.0f, 1.0f - cos_i * cos_i);
    bool cannot_refract = sin2_t > 1.0f;
    if (cannot_refract) return 0;
    float cos_t = sqrt(1.0f - sin2_t);
    *out = unit(eta * d + (eta * cos_i - cos_t) * n);
    return 1;
}

/* Schlick's approximation, with the cosine of the angle on the less dense side (the larger
 * angle): cos_i going into a denser medium, cos_t coming out of one. */
INLINE float schlick(float cos_i, float n1, float n2, float cos_t) {
    float r0 = (n1 - n2) / (n1 + n2);
    r0 *= r0;
    float c = (n1 <= n2) ? cos_i : cos_t;
    float m = 1.0f - c;
    return r0 + (1.0f - r0) * m * m * m * m * m;
}

/* ---- eight values at a time (float8 lanes): an area light's samples.  A function with a lane form
 * has one definition, the lane one, and its one-value form calls it with the value in every lane, so
 * both round alike bit for bit; integer to float conversions by exact bit tricks instead of
 * convert_float8 (out of line on PoCL), selects by ?:. */
#define LIGHT_LANES 8
typedef float8 light_f;
typedef int8 light_i;
typedef uint8 light_u;
typedef struct { light_f x, y, z; } light_f3; /* eight float3s, one lane each */
#define LIGHT_ARRAY(v) {(v).s0, (v).s1, (v).s2, (v).s3, (v).s4, (v).s5, (v).s6, (v).s7}

/* A float of magnitude below 2^22 plus ROUND_BIAS (1.5 * 2^23, whose bits are ROUND_BIAS_BITS) holds its
 * rounded integer part in the low mantissa bits; subtracting it again leaves that integer. */
#define ROUND_BIAS 12582912.0f
#define ROUND_BIAS_BITS 0x4b400000

/* small integers (|i| < 2^22) to float, exactly */
INLINE light_f int_to_float_lanes(light_i i) { return as_float8(i + ROUND_BIAS_BITS) - ROUND_BIAS; }

/* x^s for x in (0, 1], s > 0, lane by lane, as 2^(s log2 x), inline: PoCL's native_exp2 and native_log2 are
 * out-of-line library calls that took a fifth of a render's time.  log2 from the atanh series of
 * the mantissa in [sqrt(1/2), sqrt(2)), 2^f for |f| <= 1/2 from its Taylor series to degree 7:
 * each within 1e-8 relative before float32 rounding; results below 2^-126 flush to 0. */
INLINE light_f pow_unit_lanes(light_f x, float s) {
    light_i e = ((as_int8(x) >> 23) & 0xff) - 127;
    light_f m = as_float8((as_int8(x) & 0x007fffff) | 0x3f800000);
    light_i big = m > 1.41421356f; /* sqrt(2) */
    m = big ? m * 0.5f : m;
    e = big ? e + 1 : e;
    light_f a = (m - 1.0f) / (m + 1.0f), a2 = a * a;
    light_f ln_m = 2.0f * a * (1.0f + a2 * (1.0f / 3.0f + a2 * (0.2f + a2 * (1.0f / 7.0f + a2 * (1.0f / 9.0f)))));
    light_f y = s * (int_to_float_lanes(e) + ln_m * 1.44269504f); /* log2(e) */
    /* n = -(int)(0.5 - y): 0.5 - y >= 0.5 here, truncated by rounding to an integer and stepping down */
    light_f v = 0.5f - y;
    light_f rounded = (v + ROUND_BIAS) - ROUND_BIAS;
    light_f t = rounded > v ? rounded - 1.0f : rounded;
    light_i n = -(as_int8(t + ROUND_BIAS) - ROUND_BIAS_BITS);
    light_f f = (y - int_to_float_lanes(n)) * 0.693147181f; /* ln(2) */
    light_f ef = 1.0f + f * (1.0f + f * (0.5f + f * (1.0f / 6.0f + f * (1.0f / 24.0f + f * (1.0f / 120.0f + f * (1.0f / 720.0f + f * (1.0f / 5040.0f)))))));
    light_f r = ef * as_float8((n + 127) << 23);
    return y < -126.0f ? (light_f)(0.0f) : r;
}

/* One x^s: lane 0 of pow_unit_lanes, so a point light's highlight and an area light's lanes round alike. */
INLINE float pow_unit(float x, float s) { return pow_unit_lanes((light_f)(x), s).s0; }

/* Lambert + Blinn-Phong at pt, per unit of the light's value at the surface, for eight unit directions
 * l towards the light (blinn_phong: for one).
 * The unnormalised model (physical = false): kd (n.l) + ks (n.h)^s, no 1/pi.
 * The physical model (lights with inverse-square falloff): the energy-conserving
 * BRDF kd/pi + ks (s+8)/(8 pi) (n.h)^s (normalised Blinn-Phong), times n.l. */
INLINE light_f3 blinn_phong_lanes(const ShadingPoint *pt, light_f3 l, bool physical) {
    float3 n = pt->n, v = pt->v, kd = pt->kd, ks = pt->ks;
    float shininess = pt->shininess;
    light_f n_dot = n.x * l.x + n.y * l.y + n.z * l.z;
    light_f n_dot_l = n_dot > 0.0f ? n_dot : (light_f)(0.0f);
    light_f3 h = {l.x + v.x, l.y + v.y, l.z + v.z};
    light_f h_len = sqrt(h.x * h.x + h.y * h.y + h.z * h.z);
    h.x /= h_len; h.y /= h_len; h.z /= h_len;
    /* (n.h)^s only where it is used: lit side, specular colour present (the pow is the costly part) */
    light_f spec = (light_f)(0.0f);
    if (ks.x > 0.0f || ks.y > 0.0f || ks.z > 0.0f) {
        light_f n_dot_h = n.x * h.x + n.y * h.y + n.z * h.z;
        light_f x = n_dot_h > MIN_N_DOT_H ? n_dot_h : (light_f)(MIN_N_DOT_H);
        spec = shininess > 0.0f ? pow_unit_lanes(x, shininess) : (light_f)(1.0f);
        spec = n_dot_l > 0.0f ? spec : (light_f)(0.0f);
    }
    light_f3 out;
    if (physical) {
        /* kd in lanes before the product: kd/pi + ks w contracts to fma(kd, 1/pi, ks w) (kd.x * INV_PI of two
           floats would be splat, and the fma would take ks w instead) */
        light_f ks_w = (shininess + 8.0f) * 0.125f * INV_PI * spec;
        out.x = ((light_f)(kd.x) * INV_PI + ks.x * ks_w) * n_dot_l;
        out.y = ((light_f)(kd.y) * INV_PI + ks.y * ks_w) * n_dot_l;
        out.z = ((light_f)(kd.z) * INV_PI + ks.z * ks_w) * n_dot_l;
    } else {
        out.x = kd.x * n_dot_l + ks.x * spec;
        out.y = kd.y * n_dot_l + ks.y * spec;
        out.z = kd.z * n_dot_l + ks.z * spec;
    }
    return out;
}

/* blinn_phong_lanes for one direction l: lane 0 of l in every lane */
INLINE float3 blinn_phong(const ShadingPoint *pt, float3 l, bool physical) {
    light_f3 lanes = {(light_f)(l.x), (light_f)(l.y), (light_f)(l.z)};
    light_f3 b = blinn_phong_lanes(pt, lanes, physical);
    return (float3)(b.x.s0, b.y.s0, b.z.s0);
}

#if SHAFTS_ON
#define SHAFT_PARAMS int shaft_side, ShaftCandidates *cand
#define SHAFT_ARGS shaft_side, &cand
#define NO_SHAFT 0, 0
#else
#define SHAFT_PARAMS int shaft_side
#define SHAFT_ARGS 0
#define NO_SHAFT 0
#endif

/* Fraction of the light reaching pt->p + l dist (l unit) along a shadow ray leaving from the side of
 * the surface it goes towards: through the shaft's candidates when the shaft serves that side
 * (shaft_side 1: front, -1: back), else by traversing the tree. */
INLINE float sample_transmittance(const SceneView *sc, const ShadingPoint *pt, float3 l, float dist, SHAFT_PARAMS,
                                  uint *visits) {
    bool front = dot3(pt->n_geo, l) >= 0.0f;
    float3 origin = front ? pt->origin_front : pt->origin_back;
#if SHAFTS_ON
    bool by_shaft = shaft_side != 0 && front == (shaft_side > 0);
    if (by_shaft && cand->n == 0) return cand->crossed_T; /* nothing more to cross */
#endif
    Ray sr = make_ray(origin, l);
    float t_max = (dist == INF_T) ? INF_T : norm(pt->p + l * dist - origin);
#if SHAFTS_ON
    if (by_shaft) return shaft_transmittance(cand, &sc->geo, material_pass(sc->tex.materials), sr, t_max);
#endif
#if ALPHA_TEST
    return alpha_transmittance(&sc->geo, sc->tex, sr, t_max, visits); /* one ray's walk: shafts are off (shaft.h) */
#else
    return transmittance(&sc->geo, sr, 0.0f, t_max, material_pass(sc->tex.materials), visits);
#endif
}

/* A point or directional light's one sample at pt: its light added to *total; returns the fraction
 * of the light that reached pt. */
INLINE float point_light(const SceneView *sc, const ShadingPoint *pt, __global const Light *light, float3 *total,
                         uint *visits, uint *rays) {
    bool inverse_square = light->falloff == LIGHT_FALLOFF_INVERSE_SQUARE;
    float3 l;
    float dist, falloff = 1.0f;
    if (light->type == LIGHT_DIRECTIONAL) {
        l = -unit(vload3(0, light->direction));
        dist = INF_T;
    } else {
        l = vload3(0, light->position) - pt->p;
        dist = norm(l);
        l /= dist;
        if (inverse_square) {
            falloff = 1.0f / (dist * dist);
            /* a light within 1e-5 of the point overflowed float32 to inf (issue 14): the falloff
               is capped at 1/r^2 for r = 1e-5; only lights touching a surface reach the cap */
            falloff = min_f(falloff, MAX_FALLOFF);
        }
        if (light->type == LIGHT_SPOT) falloff *= spot_profile(light, 0, -l); /* a point light times its cone */
    }
    float T = 1.0f;
    if (dot3(pt->n, l) > 0.0f) {
        T = sample_transmittance(sc, pt, l, dist, NO_SHAFT, visits);
        *rays += 1;
        /* a blocked sample adds nothing: skip the shading (its pow is a third of a render's time);
           one sample: the light's whole intensity */
        if (T > 0.0f)
            *total += (T * light->intensity * falloff) * vload3(0, light->colour) * blinn_phong(pt, l, inverse_square);
    }
    return T;
}

/* An area light: a parallelogram from `corner` along its edges a and b, and its unit normal and area. */
typedef struct {
    float3 corner, edge_a, edge_b;
    float3 normal;
    float area;
} Parallelogram;

INLINE Parallelogram parallelogram(__global const Light *light) {
    Parallelogram pg;
    pg.corner = vload3(0, light->position);
    pg.edge_a = vload3(0, light->edge_a);
    pg.edge_b = vload3(0, light->edge_b);
    float3 normal = cross3(pg.edge_a, pg.edge_b);
    pg.area = norm(normal);
    pg.normal = pg.area > 0.0f ? normal / pg.area : normal;
    return pg;
}

/* Samples per side of a light: n x n for an area light, 1 for the others. */
INLINE uint samples_per_side(const SceneView *sc, __global const Light *light) {
    if (light->type != LIGHT_AREA) return 1;
    return sc->light_samples > 0 ? (uint)sc->light_samples : (uint)light->samples;
}

/* Eight samples of an area light, in lanes. */
typedef struct {
    light_f3 l;      /* unit direction from the shading point towards the sample's point on the light */
    light_f dist;    /* distance to that point */
    light_f falloff; /* 1, or with inverse-square falloff A cos(theta_light) / r^2, capped */
    light_f n_dot;   /* n.l: the sample lights the surface where > 0 */
} AreaLanes;

/* Samples base .. base + LIGHT_LANES - 1 of an area light of n_side x n_side at pt; (*row, *col) is the
 * cell of sample `base` and is moved past the eight.  Their random numbers are dimensions
 * rng->dim + 2 (sample index) and the next one. */
INLINE AreaLanes area_lanes(const SceneView *sc, const ShadingPoint *pt, const Parallelogram *pg, bool inverse_square,
                            uint n_side, const Rng *rng, uint base, uint *row, uint *col) {
    float cell_p[LIGHT_LANES], cell_q[LIGHT_LANES];
    for (int j = 0; j < LIGHT_LANES; ++j) {
        cell_p[j] = (float)*row; cell_q[j] = (float)*col;
        if (++*col == n_side) { *col = 0; ++*row; }
    }
    light_f fp = (light_f)(cell_p[0], cell_p[1], cell_p[2], cell_p[3], cell_p[4], cell_p[5], cell_p[6], cell_p[7]);
    light_f fq = (light_f)(cell_q[0], cell_q[1], cell_q[2], cell_q[3], cell_q[4], cell_q[5], cell_q[6], cell_q[7]);
    light_u dim = (light_u)(rng->dim + 2u * base) + (light_u)(0, 2, 4, 6, 8, 10, 12, 14);
    light_f xi_a = rng_lanes(rng, dim), xi_b = rng_lanes(rng, dim + 1u);
    /* the light's point: stratified, corner + (p + xi)/n a + (q + xi')/n b, one jittered
       point per cell; random: corner + xi a + xi' b, ignoring the cells (to show what strata buy) */
    float fn = (float)n_side;
    light_f ua = sc->light_stratified ? (fp + xi_a) / fn : xi_a;
    light_f ub = sc->light_stratified ? (fq + xi_b) / fn : xi_b;
    float3 c = pg->corner, a = pg->edge_a, b = pg->edge_b, p = pt->p;
    AreaLanes s;
    s.l.x = c.x + ua * a.x + ub * b.x - p.x;
    s.l.y = c.y + ua * a.y + ub * b.y - p.y;
    s.l.z = c.z + ua * a.z + ub * b.z - p.z;
    s.dist = sqrt(s.l.x * s.l.x + s.l.y * s.l.y + s.l.z * s.l.z);
    s.l.x /= s.dist; s.l.y /= s.dist; s.l.z /= s.dist;
    s.falloff = (light_f)(1.0f);
    if (inverse_square) { /* as for a point light, and: */
        s.falloff = 1.0f / (s.dist * s.dist);
        /* an area light's I is radiance: E = I * A cos(theta_light) / r^2 per unit of solid angle */
        light_f cos_light = pg->normal.x * s.l.x + pg->normal.y * s.l.y + pg->normal.z * s.l.z;
        s.falloff *= pg->area * as_float8(as_uint8(cos_light) & 0x7fffffffu);
        s.falloff = s.falloff < MAX_FALLOFF ? s.falloff : (light_f)(MAX_FALLOFF);
    }
    float3 n = pt->n;
    s.n_dot = n.x * s.l.x + n.y * s.l.y + n.z * s.l.z;
    return s;
}

#if SHAFTS_ON
/* The shaft from pt's shadow-ray origin to the light (kernels/shaft.h): its candidates in *cand, and the
 * side whose rays it serves (1: front, -1: back), or 0: the rays traverse the tree (no shaft could be
 * built, or it met too many candidates). */
INLINE int start_shaft(const SceneView *sc, const ShadingPoint *pt, const Parallelogram *pg, ShaftCandidates *cand,
                       uint *visits) {
    /* the light straddles the tangent plane: a shaft for the front rays, the own surface kept */
    int side = light_side(pt->p, pt->n_geo, pg->corner, pg->edge_a, pg->edge_b);
    Shaft sh;
    if (make_shaft(side >= 0 ? pt->origin_front : pt->origin_back, pg->corner, pg->edge_a, pg->edge_b, &sh) &&
        shaft_candidates(&sh, &sc->geo, material_pass(sc->tex.materials), side != 0 ? pt->slot : -1, cand, visits))
        return side >= 0 ? 1 : -1;
    return 0;
}
#endif

/* An area light's n x n samples at pt, eight at a time in lanes (area_lanes), the shadow rays one by one, then the
 * eight's BRDF in lanes where one of them lights the surface; each sample's light added to *total in sample order.
 * Returns the sum of the samples' transmittances; takes 2 n^2 dimensions of rng. */
INLINE float area_light(const SceneView *sc, const ShadingPoint *pt, __global const Light *light, Rng *rng,
                        float3 *total, uint *visits, uint *rays) {
    Parallelogram pg = parallelogram(light);
    bool inverse_square = light->falloff == LIGHT_FALLOFF_INVERSE_SQUARE;
    uint n_side = samples_per_side(sc, light), n2 = n_side * n_side;
    float weight = light->intensity / (float)(n_side * n_side);
    float3 colour = vload3(0, light->colour);
    float visible = 0.0f;
#if SHAFTS_ON
    /* the rays all leave from one side: one shaft traversal finds what they may meet; else (or with too
       many candidates) each ray traverses the tree.  Built at the first sample that sends a ray: a
       surface facing away from the light needs none. */
    int shaft_side = 0; /* 1, -1: the samples whose rays leave from the front, back origin use the shaft */
    ShaftCandidates cand;
    bool shaft_pending = n_side > 1;
#endif
    uint row = 0, col = 0;
    for (uint base = 0; base < n2; base += LIGHT_LANES) {
        AreaLanes s = area_lanes(sc, pt, &pg, inverse_square, n_side, rng, base, &row, &col);
        float al_x[LIGHT_LANES] = LIGHT_ARRAY(s.l.x), al_y[LIGHT_LANES] = LIGHT_ARRAY(s.l.y), al_z[LIGHT_LANES] = LIGHT_ARRAY(s.l.z);
        float a_dist[LIGHT_LANES] = LIGHT_ARRAY(s.dist), a_fall[LIGHT_LANES] = LIGHT_ARRAY(s.falloff);
        float a_ndot[LIGHT_LANES] = LIGHT_ARRAY(s.n_dot), a_T[LIGHT_LANES];
        uint lanes = n2 - base < LIGHT_LANES ? n2 - base : LIGHT_LANES;
        bool lit = false; /* a sample that faces the surface and gets through */
        for (uint j = 0; j < lanes; ++j) {
            float T = 1.0f;
            if (a_ndot[j] > 0.0f) {
#if SHAFTS_ON
                if (shaft_pending) {
                    shaft_pending = false;
                    shaft_side = start_shaft(sc, pt, &pg, &cand, visits);
                }
#endif
                float3 l = (float3)(al_x[j], al_y[j], al_z[j]);
                T = sample_transmittance(sc, pt, l, a_dist[j], SHAFT_ARGS, visits);
                *rays += 1;
                lit |= T > 0.0f;
            }
            a_T[j] = T;
            visible += T;
        }
        if (!lit) continue; /* the eight in shadow or behind the surface: no BRDF (its power is the costly part) */
        light_f3 brdf = blinn_phong_lanes(pt, s.l, inverse_square);
        float a_bx[LIGHT_LANES] = LIGHT_ARRAY(brdf.x), a_by[LIGHT_LANES] = LIGHT_ARRAY(brdf.y), a_bz[LIGHT_LANES] = LIGHT_ARRAY(brdf.z);
        for (uint j = 0; j < lanes; ++j)
            if (a_ndot[j] > 0.0f && a_T[j] > 0.0f)
                *total += (a_T[j] * weight * a_fall[j]) * colour * (float3)(a_bx[j], a_by[j], a_bz[j]);
    }
    rng->dim += 2u * n2;
    return visible;
}

/* Light from every light source at pt, and (when `shadow` is not null) the
 * fraction of each light that shadow rays found unblocked. */
INLINE float3 direct_light(const SceneView *sc, ShadingPoint pt, Rng *rng, __global float *shadow, uint *visits,
                           uint *rays) {
    float3 total = (float3)(0.0f);
    /* shadow rays start off the surface on the side they leave towards */
    pt.origin_front = offset_origin(pt.p, pt.p_err, pt.n_geo);
    pt.origin_back = offset_origin(pt.p, pt.p_err, -pt.n_geo);
    for (int li = 0; li < sc->n_lights; ++li) {
        __global const Light *light = sc->lights + li;
        float visible = light->type == LIGHT_AREA ? area_light(sc, &pt, light, rng, &total, visits, rays)
                                                  : point_light(sc, &pt, light, &total, visits, rays);
        uint n_side = samples_per_side(sc, light);
        if (shadow) shadow[li] = visible / (float)(n_side * n_side);
    }
    return total;
}

/* ---- following a camera ray */

/* The rays still to follow, last in first out (ALPHA_TEST: room for BLEND's see-through rays too). */
#if ALPHA_TEST
#define WHITTED_STACK (RAY_STACK + ALPHA_LAYERS)
#else
#define WHITTED_STACK RAY_STACK
#endif
typedef struct {
    float4 o[WHITTED_STACK], d[WHITTED_STACK], w[WHITTED_STACK]; /* (origin, medium IOR) (direction, depth) (weight, 0) */
    int n;
} RayStack;

INLINE void push_ray(RayStack *s, float3 o, float medium, float3 d, int depth, float3 w) {
    if (s->n == WHITTED_STACK) return; /* cannot happen: a path holds at most max_depth + 1 rays */
    s->o[s->n] = (float4)(o, medium);
    s->d[s->n] = (float4)(d, (float)depth);
    s->w[s->n] = (float4)(w, 0.0f);
    ++s->n;
}

/* The Whitted view of surface point f with material m (kernels/surface.h), hit h: what the lights shade. */
INLINE ShadingPoint shading_point(const Surface *f, const MaterialPoint *m, Hit h) {
    ShadingPoint pt;
    pt.p = f->p; pt.p_err = f->p_err;
    pt.n = f->n_shade; pt.n_geo = f->n_geo;
    pt.v = -f->d;
    pt.kd = m->kd; pt.ks = m->ks;
    pt.shininess = m->shininess;
    pt.slot = h.slot;
    return pt;
}

/* What the surface at pt passes on from a ray along d of weight w in `medium`: mirror reflection, then
 * the transparent part, refracted or (total internal reflection) all reflected; pushed as rays of
 * depth + 1. */
INLINE void bounce(const SceneView *sc, RayStack *stack, const ShadingPoint *pt, const MaterialPoint *m, bool front_face,
                   float3 d, float3 w, float medium, int depth) {
    float transparency = m->transparency, mirror = m->mirror, ior = m->ior;
    float3 w_reflect = w * (1.0f - transparency) * mirror;
    float3 w_refract = (float3)(0.0f);
    float3 refracted = (float3)(0.0f);
    float n1 = front_face ? medium : ior;
    float n2 = front_face ? ior : 1.0f; /* leaving an object enters air: objects do not nest */
    if (transparency > 0.0f) {
        float cos_i = -dot3(d, pt->n);
        if (refract_dir(d, pt->n, n1 / n2, &refracted)) {
            float F = 0.0f;
            if (sc->fresnel) F = schlick(cos_i, n1, n2, -dot3(refracted, pt->n));
            w_reflect += w * transparency * F;
            w_refract = w * transparency * (1.0f - F);
        } else { /* total internal reflection: all of it is reflected */
            w_reflect += w * transparency;
        }
    }
    if (max3(w_refract) > 0.0f)
        push_ray(stack, offset_origin(pt->p, pt->p_err, -pt->n_geo), n2, refracted, depth + 1, w_refract);
    if (max3(w_reflect) > 0.0f)
        push_ray(stack, offset_origin(pt->p, pt->p_err, pt->n_geo), medium, reflect_dir(d, pt->n), depth + 1, w_reflect);
}

/* Colour seen along one camera ray.  When `ids` is not null it receives the object ids met on the way
 * and the primary hit's facet (layout.ID_RECORD_DTYPE). */
INLINE float3 trace_path(const SceneView *sc, Ray primary, Rng *rng, __global IdRecord *ids, __global float *shadow,
                         uint *visits, uint *rays) {
    RayStack stack;
    stack.n = 0;
    push_ray(&stack, primary.o, 1.0f, primary.d, 0, (float3)(1.0f));
    float3 colour = (float3)(0.0f);
    int n_ids = 0;
    bool first_hit = true;
    if (ids) ids->facet = -1;
    while (stack.n > 0) {
        --stack.n;
        float3 o = stack.o[stack.n].xyz, d = stack.d[stack.n].xyz, w = stack.w[stack.n].xyz;
        float medium = stack.o[stack.n].w;
        int depth = (int)stack.d[stack.n].w;
        float opacity; /* BLEND's share of the ray the point stops (alpha.h seen_hit) */
        Hit h = seen_hit(&sc->geo, sc->tex, make_ray(o, d), 0.0f, INF_T, depth == 0, 0, &opacity, visits);
        *rays += 1;
        int object = hit_object(&sc->geo, h);
        if (ids && n_ids < PATH_LEN) ids->path[n_ids++] = object;
        if (h.id < 0) {
            colour += w * (sc->env.m.width > 0 ? env_radiance(&sc->env, d) : sc->background);
            first_hit = false;
            continue;
        }
        Surface f = surface_at(&sc->geo, sc->normals, sc->tex, h, o, d);
        MaterialPoint m = material_at(sc->tex, sc->tex.materials, &f);
        ShadingPoint pt = shading_point(&f, &m, h);
        if (opacity < 1.0f) { /* BLEND: what lies behind the point, 1 - alpha of the ray, on the same footing */
            push_ray(&stack, offset_origin(pt.p, pt.p_err, -pt.n_geo), medium, d, depth, w * (1.0f - opacity));
            w *= opacity;
        }
        if (ids && first_hit && !f.smooth && !f.sphere) ids->facet = h.id;
#if WRITE_AOV
        if (first_hit && sc->aov) {
            vstore3(pt.n, 0, sc->aov->normal);
            sc->aov->depth = h.t;
            vstore3(pt.kd * m.occlusion, 0, sc->aov->albedo);
        }
#endif
        /* a perfect mirror or fully clear glass shows none of its own shading: skip the shadow rays,
           unless this is the primary hit whose light visibility the edge detector needs */
        float3 surface_weight = w * (1.0f - m.transparency) * (1.0f - m.mirror);
        __global float *shadow_here = first_hit ? shadow : 0;
        if (max3(surface_weight) > 0.0f || shadow_here) {
            float3 surface = sc->ambient * (pt.kd * m.occlusion) + direct_light(sc, pt, rng, shadow_here, visits, rays);
            colour += surface_weight * surface;
        }
        first_hit = false;
        if (depth < sc->max_depth) bounce(sc, &stack, &pt, &m, f.front, d, w, medium, depth);
    }
    if (ids)
        for (int k = n_ids; k < PATH_LEN; ++k) ids->path[k] = -1;
    return colour;
}

#endif
