/* Whitted shading: ambient + Lambert + Blinn-Phong from point, directional
 * and parallelogram area lights with shadow rays, then mirror reflection and
 * refraction (Snell's law, total internal reflection, optional Schlick
 * Fresnel) on an explicit ray stack instead of recursion. */
#ifndef CLRENDER_SHADE_H
#define CLRENDER_SHADE_H

#include "common.h"
#include "intersect.h"
#include "sampling.h"
#include "shaft.h"

#ifndef WRITE_AOV
#define WRITE_AOV 0 /* 1: the render kernel also writes the primary hit's AOVs (renderer.py, --aov) */
#endif

/* What the render kernel shades with (the Python side's clrender.scene.Scene, packed). */
typedef struct {
    Geometry geo;
    __global const VertexNormals *normals; /* per primitive id */
    __global const Light *lights;
    int n_lights;
    int light_samples;   /* > 0 overrides every area light's samples per side */
    int max_depth;       /* bounces after the primary hit */
    int fresnel;         /* 0: transparency splits as the seed; 1: Schlick */
    int light_stratified; /* 1: one jittered sample per cell of an area light (the seed); 0: uniform random */
    float3 background;
    float3 ambient;
#if WRITE_AOV
    __global AovRecord *aov; /* null, or this pixel's primary-hit record */
#endif
} SceneView;

#define MAX_FALLOFF 1e10f /* cap of 1/r^2 (r = 1e-5) and of an area light's A cos / r^2 */

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

/* ---- an area light's samples eight at a time (float8 lanes), the same operations in the same order
 * as the one-sample code (direct_light's other lights; rng.h's rng_lanes), so every lane's value is bit
 * for bit the one-sample value: integer to float conversions by exact bit tricks instead of
 * convert_float8 (out of line on PoCL), selects by ?:. */
#define LIGHT_LANES 8
typedef float8 light_f;
typedef int8 light_i;
typedef uint8 light_u;
#define LIGHT_ARRAY(v) {(v).s0, (v).s1, (v).s2, (v).s3, (v).s4, (v).s5, (v).s6, (v).s7}

/* small integers (|i| < 2^22) to float, exactly */
INLINE light_f int_to_float_lanes(light_i i) { return as_float8(i + 0x4b400000) - 12582912.0f; }

/* x^s for x in (0, 1], s > 0, lane by lane, as 2^(s log2 x), inline: PoCL's native_exp2 and native_log2 are
 * out-of-line library calls that took a fifth of a render's time.  log2 from the atanh series of
 * the mantissa in [sqrt(1/2), sqrt(2)), 2^f for |f| <= 1/2 from its Taylor series to degree 7:
 * each within 1e-8 relative before float32 rounding; results below 2^-126 flush to 0. */
INLINE light_f pow_unit_lanes(light_f x, float s) {
    light_i e = ((as_int8(x) >> 23) & 0xff) - 127;
    light_f m = as_float8((as_int8(x) & 0x007fffff) | 0x3f800000);
    light_i big = m > 1.41421356f;
    m = big ? m * 0.5f : m;
    e = big ? e + 1 : e;
    light_f a = (m - 1.0f) / (m + 1.0f), a2 = a * a;
    light_f ln_m = 2.0f * a * (1.0f + a2 * (1.0f / 3.0f + a2 * (0.2f + a2 * (1.0f / 7.0f + a2 * (1.0f / 9.0f)))));
    light_f y = s * (int_to_float_lanes(e) + ln_m * 1.44269504f);
    /* n = -(int)(0.5 - y): 0.5 - y >= 0.5 here, truncated by rounding to an integer and stepping down */
    light_f v = 0.5f - y;
    light_f rounded = (v + 12582912.0f) - 12582912.0f;
    light_f t = rounded > v ? rounded - 1.0f : rounded;
    light_i n = -(as_int8(t + 12582912.0f) - 0x4b400000);
    light_f f = (y - int_to_float_lanes(n)) * 0.693147181f;
    light_f ef = 1.0f + f * (1.0f + f * (0.5f + f * (1.0f / 6.0f + f * (1.0f / 24.0f + f * (1.0f / 120.0f + f * (1.0f / 720.0f + f * (1.0f / 5040.0f)))))));
    light_f r = ef * as_float8((n + 127) << 23);
    return y < -126.0f ? (light_f)(0.0f) : r;
}

/* One x^s: lane 0 of pow_unit_lanes, so a point light's highlight and an area light's lanes round alike. */
INLINE float pow_unit(float x, float s) { return pow_unit_lanes((light_f)(x), s).s0; }

/* Lambert + Blinn-Phong, per unit of the light's value at the surface.
 * The seed's model (physical = false): kd (n.l) + ks (n.h)^s, no 1/pi.
 * The physical model (lights with inverse-square falloff): the energy-conserving
 * BRDF kd/pi + ks (s+8)/(8 pi) (n.h)^s (normalised Blinn-Phong), times n.l. */
INLINE float3 blinn_phong(float3 n, float3 l, float3 v, float4 kd_shine, float4 ks_mirror, bool physical) {
    float n_dot_l = max_f(dot3(n, l), 0.0f);
    float3 h = unit(l + v);
    float shininess = kd_shine.w;
    /* (n.h)^s only where it is used: lit side, specular colour present (the pow is the costly part) */
    bool specular = n_dot_l > 0.0f && (ks_mirror.x > 0.0f || ks_mirror.y > 0.0f || ks_mirror.z > 0.0f);
    float spec = !specular ? 0.0f
                 : (shininess > 0.0f) ? pow_unit(max_f(dot3(n, h), 1e-30f), shininess) : 1.0f;
    if (physical) {
        const float INV_PI = 0.318309886f;
        return (kd_shine.xyz * INV_PI + ks_mirror.xyz * ((shininess + 8.0f) * 0.125f * INV_PI * spec)) * n_dot_l;
    }
    return kd_shine.xyz * n_dot_l + ks_mirror.xyz * (n_dot_l > 0.0f ? spec : 0.0f);
}

#if SHAFTS_ON
#define SHAFT_PARAMS int shaft_side, ShaftCandidates *cand
#define SHAFT_ARGS shaft_side, &cand
#else
#define SHAFT_PARAMS int shaft_side
#define SHAFT_ARGS 0
#endif

/* Fraction of the light reaching p + l dist (l unit) along a shadow ray leaving from the side of
 * the surface it goes towards: through the shaft's candidates when the shaft serves that side
 * (shaft_side 1: front, -1: back), else by traversing the tree. */
INLINE float sample_transmittance(const SceneView *sc, float3 p, float3 l, float dist, float3 n_geo, float3 origin_front,
                                  float3 origin_back, SHAFT_PARAMS, uint *visits) {
    bool front = dot3(n_geo, l) >= 0.0f;
    float3 origin = front ? origin_front : origin_back;
#if SHAFTS_ON
    if (shaft_side != 0 && front == (shaft_side > 0)) {
        if (cand->n == 0) return cand->crossed_T; /* nothing more to cross */
        Ray sr = make_ray(origin, l);
        float t_max = (dist == INF_T) ? INF_T : norm(p + l * dist - origin);
        return shaft_transmittance(cand, &sc->geo, sr, t_max);
    }
#endif
    Ray sr = make_ray(origin, l);
    float t_max = (dist == INF_T) ? INF_T : norm(p + l * dist - origin);
    return transmittance(&sc->geo, sr, 0.0f, t_max, false, visits);
}

/* Light from every light source at p, and (when `shadow` is not null) the
 * fraction of each light that shadow rays found unblocked. */
INLINE float3 direct_light(const SceneView *sc, float3 p, float3 p_err, float3 n, float3 n_geo, float3 v,
                           float4 kd, float4 ks, int own_slot, Rng *rng, __global float *shadow, uint *visits,
                           uint *rays) {
    float3 total = (float3)(0.0f);
    /* shadow rays start off the surface on the side they leave towards */
    float3 origin_front = offset_origin(p, p_err, n_geo), origin_back = offset_origin(p, p_err, -n_geo);
    for (int li = 0; li < sc->n_lights; ++li) {
        __global const Light *light = sc->lights + li;
        int type = light->type;
        float intensity = light->intensity;
        bool inverse_square = light->falloff == LIGHT_FALLOFF_INVERSE_SQUARE;
        float3 pos = vload3(0, light->position);
        float3 colour = vload3(0, light->colour);
        uint n_side = 1;
        float3 edge_a = (float3)(0.0f), edge_b = (float3)(0.0f);
        if (type == LIGHT_AREA) {
            n_side = sc->light_samples > 0 ? (uint)sc->light_samples : (uint)light->samples;
            edge_a = vload3(0, light->edge_a);
            edge_b = vload3(0, light->edge_b);
        }
        float3 light_normal = cross3(edge_a, edge_b);
        float area = norm(light_normal);
        light_normal = area > 0.0f ? light_normal / area : light_normal;
        float weight = intensity / (float)(n_side * n_side);
        float visible = 0.0f;
        int shaft_side = 0; /* 1, -1: the samples whose rays leave from the front, back origin use the shaft */
#if SHAFTS_ON
        /* an area light's rays all leave from one side: one shaft traversal finds what they may meet
           (kernels/shaft.h); else (or with too many candidates) each ray traverses the tree.  Built at
           the first sample that sends a ray: a surface facing away from the light needs none. */
        ShaftCandidates cand;
        bool shaft_pending = type == LIGHT_AREA && n_side > 1;
#endif
        if (type == LIGHT_AREA) {
            /* eight samples at a time: the light point, direction, falloff and Blinn-Phong in lanes,
               the shadow rays one by one; sums in sample order */
            uint n2 = n_side * n_side;
            float fn = (float)n_side;
            float shininess = kd.w;
            bool has_specular = ks.x > 0.0f || ks.y > 0.0f || ks.z > 0.0f;
            uint sp = 0, sq = 0;
            for (uint base = 0; base < n2; base += LIGHT_LANES) {
                float cell_p[LIGHT_LANES], cell_q[LIGHT_LANES];
                for (int j = 0; j < LIGHT_LANES; ++j) {
                    cell_p[j] = (float)sp; cell_q[j] = (float)sq;
                    if (++sq == n_side) { sq = 0; ++sp; }
                }
                light_f fp = (light_f)(cell_p[0], cell_p[1], cell_p[2], cell_p[3], cell_p[4], cell_p[5], cell_p[6], cell_p[7]);
                light_f fq = (light_f)(cell_q[0], cell_q[1], cell_q[2], cell_q[3], cell_q[4], cell_q[5], cell_q[6], cell_q[7]);
                light_u dim = (light_u)(rng->dim + 2u * base) + (light_u)(0, 2, 4, 6, 8, 10, 12, 14);
                light_f xi_a = rng_lanes(rng, dim), xi_b = rng_lanes(rng, dim + 1u);
                /* the light's point: stratified (the seed), corner + (p + xi)/n a + (q + xi')/n b, one jittered
                   point per cell; random: corner + xi a + xi' b, ignoring the cells (to show what strata buy) */
                light_f ua = sc->light_stratified ? (fp + xi_a) / fn : xi_a;
                light_f ub = sc->light_stratified ? (fq + xi_b) / fn : xi_b;
                light_f lx = pos.x + ua * edge_a.x + ub * edge_b.x - p.x;
                light_f ly = pos.y + ua * edge_a.y + ub * edge_b.y - p.y;
                light_f lz = pos.z + ua * edge_a.z + ub * edge_b.z - p.z;
                light_f dist = sqrt(lx * lx + ly * ly + lz * lz);
                lx /= dist; ly /= dist; lz /= dist;
                light_f falloff = (light_f)(1.0f);
                if (inverse_square) { /* as for a point light, and: */
                    falloff = 1.0f / (dist * dist);
                    /* an area light's I is radiance: E = I * A cos(theta_light) / r^2 per unit of solid angle */
                    light_f cos_light = light_normal.x * lx + light_normal.y * ly + light_normal.z * lz;
                    falloff *= area * as_float8(as_uint8(cos_light) & 0x7fffffffu);
                    falloff = falloff < MAX_FALLOFF ? falloff : (light_f)(MAX_FALLOFF);
                }
                light_f n_dot = n.x * lx + n.y * ly + n.z * lz;
                /* blinn_phong */
                light_f n_dot_l = n_dot > 0.0f ? n_dot : (light_f)(0.0f);
                light_f hx = lx + v.x, hy = ly + v.y, hz = lz + v.z;
                light_f h_len = sqrt(hx * hx + hy * hy + hz * hz);
                hx /= h_len; hy /= h_len; hz /= h_len;
                light_f spec = (light_f)(0.0f);
                if (has_specular) {
                    light_f n_dot_h = n.x * hx + n.y * hy + n.z * hz;
                    spec = shininess > 0.0f ? pow_unit_lanes(n_dot_h > 1e-30f ? n_dot_h : (light_f)(1e-30f), shininess)
                                            : (light_f)(1.0f);
                    spec = n_dot_l > 0.0f ? spec : (light_f)(0.0f);
                }
                light_f bx, by, bz;
                if (inverse_square) {
                    const float INV_PI = 0.318309886f;
                    light_f ks_w = (shininess + 8.0f) * 0.125f * INV_PI * spec;
                    bx = (kd.x * INV_PI + ks.x * ks_w) * n_dot_l;
                    by = (kd.y * INV_PI + ks.y * ks_w) * n_dot_l;
                    bz = (kd.z * INV_PI + ks.z * ks_w) * n_dot_l;
                } else {
                    light_f spec_lit = n_dot_l > 0.0f ? spec : (light_f)(0.0f);
                    bx = kd.x * n_dot_l + ks.x * spec_lit;
                    by = kd.y * n_dot_l + ks.y * spec_lit;
                    bz = kd.z * n_dot_l + ks.z * spec_lit;
                }
                float al_x[LIGHT_LANES] = LIGHT_ARRAY(lx), al_y[LIGHT_LANES] = LIGHT_ARRAY(ly), al_z[LIGHT_LANES] = LIGHT_ARRAY(lz);
                float a_dist[LIGHT_LANES] = LIGHT_ARRAY(dist), a_fall[LIGHT_LANES] = LIGHT_ARRAY(falloff);
                float a_ndot[LIGHT_LANES] = LIGHT_ARRAY(n_dot);
                float a_bx[LIGHT_LANES] = LIGHT_ARRAY(bx), a_by[LIGHT_LANES] = LIGHT_ARRAY(by), a_bz[LIGHT_LANES] = LIGHT_ARRAY(bz);
                uint lanes = n2 - base < LIGHT_LANES ? n2 - base : LIGHT_LANES;
                for (uint j = 0; j < lanes; ++j) {
                    float T = 1.0f;
                    if (a_ndot[j] > 0.0f) {
#if SHAFTS_ON
                        if (shaft_pending) {
                            shaft_pending = false;
                            /* the light straddles the tangent plane: a shaft for the front rays, the own
                               surface kept */
                            int side = light_side(p, n_geo, pos, edge_a, edge_b);
                            Shaft sh;
                            if (make_shaft(side >= 0 ? origin_front : origin_back, pos, edge_a, edge_b, &sh) &&
                                shaft_candidates(&sh, &sc->geo, side != 0 ? own_slot : -1, &cand, visits))
                                shaft_side = side >= 0 ? 1 : -1;
                        }
#endif
                        float3 l = (float3)(al_x[j], al_y[j], al_z[j]);
                        T = sample_transmittance(sc, p, l, a_dist[j], n_geo, origin_front, origin_back, SHAFT_ARGS, visits);
                        *rays += 1;
                        if (T > 0.0f) total += (T * weight * a_fall[j]) * colour * (float3)(a_bx[j], a_by[j], a_bz[j]);
                    }
                    visible += T;
                }
            }
            rng->dim += 2u * n2;
        } else
        for (uint sp = 0; sp < n_side; ++sp) {
            for (uint sq = 0; sq < n_side; ++sq) {
                float3 l;
                float dist, falloff = 1.0f;
                if (type == LIGHT_DIRECTIONAL) {
                    l = -unit(vload3(0, light->direction));
                    dist = INF_T;
                } else {
                    float3 target = pos; /* a point light (area lights take the lanes above) */
                    l = target - p;
                    dist = norm(l);
                    l /= dist;
                    if (inverse_square) {
                        falloff = 1.0f / (dist * dist);
                        /* a light within 1e-5 of the point overflowed float32 to inf (issue 14): the falloff
                           is capped at 1/r^2 for r = 1e-5; only lights touching a surface reach the cap */
                        falloff = min_f(falloff, MAX_FALLOFF);
                    }
                }
                float T = 1.0f;
                if (dot3(n, l) > 0.0f) {
                    T = sample_transmittance(sc, p, l, dist, n_geo, origin_front, origin_back, SHAFT_ARGS, visits);
                    *rays += 1;
                    /* a blocked sample adds nothing: skip the shading (its pow is a third of a render's time) */
                    if (T > 0.0f) total += (T * weight * falloff) * colour * blinn_phong(n, l, v, kd, ks, inverse_square);
                }
                visible += T;
            }
        }
        if (shadow) shadow[li] = visible / (float)(n_side * n_side);
    }
    return total;
}

/* Colour seen along one camera ray.  When `ids` is not null it receives the object ids met on the way
 * and the primary hit's facet (layout.ID_RECORD_DTYPE). */
INLINE float3 trace_path(const SceneView *sc, Ray primary, Rng *rng, __global IdRecord *ids, __global float *shadow,
                         uint *visits, uint *rays) {
    float4 stack_o[RAY_STACK], stack_d[RAY_STACK], stack_w[RAY_STACK]; /* o.w: medium IOR, d.w: depth */
    int sp = 0;
    stack_o[0] = (float4)(primary.o, 1.0f);
    stack_d[0] = (float4)(primary.d, 0.0f);
    stack_w[0] = (float4)(1.0f);
    sp = 1;
    float3 colour = (float3)(0.0f);
    int n_ids = 0;
    bool first_hit = true;
    if (ids) ids->facet = -1;
    while (sp > 0) {
        --sp;
        float3 o = stack_o[sp].xyz, d = stack_d[sp].xyz, w = stack_w[sp].xyz;
        float medium = stack_o[sp].w;
        int depth = (int)stack_d[sp].w;
        Ray r = make_ray(o, d);
        Hit h = closest_hit(&sc->geo, r, 0.0f, INF_T, visits);
        *rays += 1;
        int object = h.id >= 0 ? sc->geo.prim_object[h.id] : -1;
        if (ids && n_ids < PATH_LEN) ids->path[n_ids++] = object;
        if (h.id < 0) {
            colour += w * sc->background;
            first_hit = false;
            continue;
        }
        ObjectRecord obj = sc->geo.objects[object];
        if (ids && first_hit && !obj.smooth && !is_sphere(sc->geo.prims, h.slot)) ids->facet = h.id;
        __global const Material *m = sc->geo.materials + obj.material;
        float4 kd = (float4)(vload3(0, m->kd), m->shininess), ks = (float4)(vload3(0, m->ks), m->mirror);
        float transparency = m->transparency, ior = m->ior, mirror = m->mirror;

        float4 a = sc->geo.prims[PRIM_ROWS * h.slot], b = sc->geo.prims[PRIM_ROWS * h.slot + 1], c = sc->geo.prims[PRIM_ROWS * h.slot + 2];
        float3 p, p_err; /* the hit point from the primitive, and its float32 error per axis */
        float3 n_geo, n_shade;
        if (is_sphere_row(b)) {
            p = hit_point_sphere((float4)(a.xyz, b.x), o + h.t * d, &p_err);
            n_geo = unit(p - a.xyz);
            n_shade = n_geo;
        } else {
            p = hit_point_triangle(a, b, c, h.u, h.v, &p_err);
            n_geo = unit(cross3(b.xyz - a.xyz, c.xyz - a.xyz));
            n_shade = n_geo;
            if (obj.smooth) {
                __global const VertexNormals *vn = sc->normals + h.id;
                float3 n0 = vload3(0, vn->normal[0]), n1 = vload3(0, vn->normal[1]), n2 = vload3(0, vn->normal[2]);
                n_shade = unit((1.0f - h.u - h.v) * n0 + h.u * n1 + h.v * n2);
            }
        }
        bool front_face = dot3(d, n_geo) < 0.0f;
        if (!front_face) { n_geo = -n_geo; n_shade = -n_shade; }
        if (dot3(n_shade, d) >= 0.0f) n_shade = n_geo; /* interpolated normal points away: fall back */
#if WRITE_AOV
        if (first_hit && sc->aov) {
            vstore3(n_shade, 0, sc->aov->normal);
            sc->aov->depth = h.t;
            vstore3(kd.xyz, 0, sc->aov->albedo);
        }
#endif

        /* a perfect mirror or fully clear glass shows none of its own shading: skip the shadow rays,
           unless this is the primary hit whose light visibility the edge detector needs */
        float3 surface_weight = w * (1.0f - transparency) * (1.0f - mirror);
        __global float *shadow_here = first_hit ? shadow : 0;
        if (max_f(surface_weight.x, max_f(surface_weight.y, surface_weight.z)) > 0.0f || shadow_here) {
            float3 surface = sc->ambient * kd.xyz +
                             direct_light(sc, p, p_err, n_shade, n_geo, -d, kd, ks, h.slot, rng, shadow_here, visits, rays);
            colour += surface_weight * surface;
        }
        first_hit = false;
        if (depth >= sc->max_depth) continue;

        /* what the surface passes on: mirror reflection, then the transparent part */
        float3 w_reflect = w * (1.0f - transparency) * mirror;
        float3 w_refract = (float3)(0.0f);
        float3 refracted = (float3)(0.0f);
        float n1 = front_face ? medium : ior;
        float n2 = front_face ? ior : 1.0f; /* leaving an object enters air: objects do not nest */
        if (transparency > 0.0f) {
            float cos_i = -dot3(d, n_shade);
            if (refract_dir(d, n_shade, n1 / n2, &refracted)) {
                float F = 0.0f;
                if (sc->fresnel) F = schlick(cos_i, n1, n2, -dot3(refracted, n_shade));
                w_reflect += w * transparency * F;
                w_refract = w * transparency * (1.0f - F);
            } else { /* total internal reflection: all of it is reflected */
                w_reflect += w * transparency;
            }
        }
        if (max_f(w_refract.x, max_f(w_refract.y, w_refract.z)) > 0.0f && sp < RAY_STACK) {
            stack_o[sp] = (float4)(offset_origin(p, p_err, -n_geo), n2);
            stack_d[sp] = (float4)(refracted, (float)(depth + 1));
            stack_w[sp] = (float4)(w_refract, 0.0f);
            ++sp;
        }
        if (max_f(w_reflect.x, max_f(w_reflect.y, w_reflect.z)) > 0.0f && sp < RAY_STACK) {
            stack_o[sp] = (float4)(offset_origin(p, p_err, n_geo), medium);
            stack_d[sp] = (float4)(reflect_dir(d, n_shade), (float)(depth + 1));
            stack_w[sp] = (float4)(w_reflect, 0.0f);
            ++sp;
        }
    }
    if (ids)
        for (int k = n_ids; k < PATH_LEN; ++k) ids->path[k] = -1;
    return colour;
}

#endif
