/* Unidirectional path tracing (issue 25): one work-item per pixel, `spp` paths each.
 *
 * At every surface vertex the material picks ONE component at random with its own weight (the
 * stochastic mixture of pbrt-v4's MixMaterial: unbiased, and each component is then a plain BSDF of
 * kernels/bsdf.h), then
 *   - next-event estimation: a shadow ray to every point, spot and directional light, to one point of every
 *     area light, to one point of one emissive triangle (chosen in proportion to its power), and to
 *     one direction of the environment (the constant one: cosine-weighted about the shading normal; an
 *     image map: by its luminance x solid angle, kernels/envmap.h);
 *   - BSDF sampling for the next direction; a BSDF ray that reaches an area light, an emissive
 *     triangle or the environment adds its emission weighted against that light's strategy by the
 *     power heuristic (delta lights and delta lobes get no MIS: only one strategy can find them);
 *   - Russian roulette from RR_DEPTH bounces on.
 * Light units are docs/shading.md's.  Lights with falloff "none" (the seed's unnormalised model) give
 * the irradiance pi I c cos(theta) wherever they are, so a Lambert surface of albedo kd shows
 * kd I c cos(theta), as the Whitted integrator draws it; they are not surfaces, so only NEE finds them.
 * max_depth counts bounces after the primary hit (0: direct light only); Mitsuba's is max_depth + 2.
 * Shadow rays see every surface as opaque: light reaches through glass by BSDF sampling (caustics). */
#define DET_MATH 1 /* mathf.h's functions, no contraction: the same bits on every driver (docs/math.md) */
#ifndef PATH_SAMPLER
#define PATH_SAMPLER PATH_SAMPLER_INDEPENDENT /* RenderSettings.path_sampler's code (layout.PATH_SAMPLERS) */
#endif
#define RNG_SOBOL (PATH_SAMPLER == PATH_SAMPLER_SOBOL) /* rng_next's numbers: kernels/sobol.h's sequence */
#include "mathf.h"
#include "common.h"
#include "rng.h"
#include "sampling.h"
#include "sobol.h"
#include "camera.h"
#include "intersect.h"
#include "tables.h"
#include "bsdf.h"
#include "envmap.h"
#include "texture.h"
/* surface_at, material_at: the surface pipeline the Whitted integrator shares */
#include "surface.h"
/* ALPHA_TEST, seen_hit: what rays look past */
#include "alpha.h"
#include "spot.h"
/* the reconstruction filters of SPLAT_FILTER */
#include "film.h"

#ifndef RR_DEPTH
#define RR_DEPTH 3          /* Russian roulette from this many bounces on (RenderSettings.rr_depth; Mitsuba's rr_depth - 1) */
#endif
#ifndef HIDE_EMITTERS
#define HIDE_EMITTERS 0 /* 1: camera rays look past emitting triangles and see no area light or environment (Mitsuba's hide_emitters) */
#endif
#define HIDDEN_LAYERS 16 /* HIDE_EMITTERS: emitting triangles a camera ray looks past at most; the next one shows */
#define BETA_LIMIT 1e18f /* a path's throughput past this ends it (no pixel may be inf or NaN) */
#define RR_SURVIVE_MAX 0.95f /* a path continues with probability min(max throughput, this) */
/* Shadow rays to a point on a surface stop this fraction short of it, so that the emitting triangle
 * itself (met again within float32 rounding of the sampled point) does not block them. */
#define SHADOW_T_SHRINK 0.9999f
#ifndef SPLAT_RADIUS
#define SPLAT_RADIUS 0 /* 0: each pixel the filtered mean of its own samples; R > 0: (2R + 1)^2 splat slots (film.h) */
#endif
#ifndef ENV_NEE
#define ENV_NEE 1 /* 0 (tests only): no next-event estimation of an environment map, BSDF rays alone find it */
#endif
#ifndef ENV_BSDF
#define ENV_BSDF 1 /* 0 (tests only): after a non-delta vertex only NEE finds an environment map (no MIS) */
#endif
#ifndef AREA_NEE
#define AREA_NEE 1 /* 0 (tests only): no next-event estimation of physical area lights, BSDF rays alone find them */
#endif
#ifndef AREA_BSDF
#define AREA_BSDF 1 /* 0 (tests only): after a non-delta vertex only NEE finds a physical area light (no MIS) */
#endif

/* What a path sees: the geometry, the lights, the emissive triangles and the environment. */
typedef struct {
    Geometry geo;
    __global const VertexNormals *normals;
    TextureView tex;                       /* uvs, vertex colours and textures (texture.h) */
    __global const Light *lights;
    __global const Emitter *emitters;      /* emissive triangles, their power's running sum in `cdf` */
    __global const int *emitter_of_prim;   /* each primitive id's index in `emitters`, or -1 */
    EnvView env;                           /* an environment map (env.m.width > 0) in place of p.environment */
    PathParams p;
} PathScene;

/* ---------------------------------------------------------------- materials
 * The component a vertex uses: a lobe of bsdf.h with its parameters, or a delta mirror. */
#define LOBE_MIRROR (-1)

typedef struct {
    int lobe;            /* a BSDF_* code, or LOBE_MIRROR */
    BsdfParams bsdf;
    float3 glossy;       /* the seed model's diffuse+glossy component: the glossy lobe's colour ks */
    float glossy_alpha;  /* and its GGX width; glossy.x < 0: no glossy lobe */
    float glossy_prob;   /* probability of sampling the glossy lobe rather than the Lambert one */
    float3 tint;         /* glTF glass: transmitted light times base_color (KHR_materials_transmission); else 1 */
} Component;

INLINE float luminance(float3 c) { return 0.2126f * c.x + 0.7152f * c.y + 0.0722f * c.z; }

/* The seed's Blinn-Phong exponent s as a GGX width: alpha = sqrt(2 / (s + 2)) (Walter et al. 2007's
 * match of the two lobes' widths). */
INLINE float alpha_from_shininess(float s) { return max_f(sqrt(2.0f / (s + 2.0f)), GGX_ALPHA_MIN); }

/* A `type = ...` material (MATERIAL_MODEL_CONDUCTOR and after): one lobe of bsdf_exchange.h, its parameters from the
 * record; roughness 0 is the lobe's smooth (delta) form. */
INLINE Component exchange_component(Component c, const MaterialPoint *m) {
    __global const Material *g = m->g;
    bool smooth = !(m->roughness > 0.0f);
    c.bsdf.alpha = ggx_alpha_from_roughness(m->roughness);
    c.bsdf.eta = g->lobe_ior;
    c.bsdf.eta3 = vload3(0, g->eta);
    c.bsdf.k3 = vload3(0, g->k);
    c.bsdf.tint = vload3(0, g->tint);
    c.bsdf.transmit_tint = vload3(0, g->transmit_tint);
    c.bsdf.nonlinear = g->nonlinear;
    c.bsdf.coat_weight = g->coat_weight;
    c.bsdf.coat_internal = g->coat_internal;
    c.bsdf.coat_transmittance = g->coat_transmittance;
    if (m->model == MATERIAL_MODEL_CONDUCTOR) c.lobe = smooth ? BSDF_METAL_SMOOTH : BSDF_METAL;
    else if (m->model == MATERIAL_MODEL_COATED_DIFFUSE) c.lobe = smooth ? BSDF_COATED_DIFFUSE_SMOOTH : BSDF_COATED_DIFFUSE;
    else c.lobe = BSDF_THIN_DIELECTRIC;
    return c;
}

/* Pick the vertex's component with probability equal to its weight (the weights sum to 1, so the
 * throughput is not rescaled).  docs/materials.md states the rule. */
INLINE Component pick_component(const MaterialPoint *m, float u) {
    Component c;
    c.glossy = (float3)(-1.0f);
    c.glossy_alpha = 1.0f;
    c.glossy_prob = 0.0f;
    c.tint = (float3)(1.0f);
    c.bsdf.eta = m->ior; /* inside over outside (bsdf.h, the frame's +z outward): objects do not nest, outside is air */
    c.bsdf.metallic = m->metallic;
    c.bsdf.colour = m->kd;
    c.bsdf.smith = m->g->smith;
    if (m->model >= MATERIAL_MODEL_CONDUCTOR) return exchange_component(c, m);
    if (m->model == MATERIAL_MODEL_GLTF) {
        float alpha = ggx_alpha_from_roughness(m->roughness);
        c.bsdf.alpha = alpha;
        float transmit = m->transmission * (1.0f - m->metallic);
        if (u < transmit) {
            c.lobe = m->roughness > 0.0f ? BSDF_ROUGH_DIELECTRIC : BSDF_DIELECTRIC;
            c.tint = m->base_color;
            return c;
        }
        c.lobe = BSDF_GLTF;
        c.bsdf.colour = m->base_color;
        return c;
    }
    float t = m->transparency, mirror = (1.0f - t) * m->mirror;
    if (u < t) { c.lobe = BSDF_DIELECTRIC; return c; }
    if (u < t + mirror) { c.lobe = LOBE_MIRROR; c.bsdf.colour = (float3)(1.0f); return c; }
    /* Lambert kd plus a glossy GGX lobe ks, scaled together where kd + ks would exceed 1 */
    float3 kd = m->kd, ks = m->ks;
    float3 sum = kd + ks;
    float over = max_f(1.0f, max3(sum));
    kd /= over; ks /= over;
    c.lobe = BSDF_LAMBERT;
    c.bsdf.colour = kd;
    float lk = luminance(ks), ld = luminance(kd);
    if (lk > 0.0f) {
        c.glossy = ks;
        c.glossy_alpha = alpha_from_shininess(m->shininess);
        c.glossy_prob = lk / (lk + ld);
    }
    return c;
}

INLINE bool component_is_delta(Component c) {
    return c.lobe == LOBE_MIRROR || c.lobe == BSDF_DIELECTRIC || c.lobe == BSDF_METAL_SMOOTH || c.lobe == BSDF_THIN_DIELECTRIC;
}

/* glTF glass's tint on a pair of directions: base_color through the surface (wo, wi on opposite sides), 1 on
 * reflection (the extension tints only the BTDF; Fresnel reflection stays white). */
INLINE bool component_tinted(Component c, float3 wo, float3 wi) {
    return (c.lobe == BSDF_DIELECTRIC || c.lobe == BSDF_ROUGH_DIELECTRIC) && wo.z * wi.z < 0.0f;
}

/* f * |cos| of the component, local frame (delta components: 0). */
INLINE float3 component_eval(Component c, float3 wo, float3 wi) {
    if (component_is_delta(c)) return (float3)(0.0f);
    float3 f = bsdf_eval(c.lobe, c.bsdf, wo, wi);
    if (component_tinted(c, wo, wi)) f *= c.tint;
    if (c.glossy.x >= 0.0f) f += c.glossy * conductor_eval(wo, wi, (float3)(1.0f), c.glossy_alpha, SMITH_CORRELATED);
    return f;
}

INLINE float component_pdf(Component c, float3 wo, float3 wi) {
    if (component_is_delta(c)) return 0.0f;
    float pdf = bsdf_pdf(c.lobe, c.bsdf, wo, wi);
    if (c.glossy.x >= 0.0f) pdf = (1.0f - c.glossy_prob) * pdf + c.glossy_prob * conductor_pdf(wo, wi, c.glossy_alpha);
    return pdf;
}

INLINE BsdfSample component_sample(Component c, float3 wo, float u1, float2 u2) {
    if (c.lobe == LOBE_MIRROR) {
        BsdfSample s = no_sample();
        if (wo.z <= 0.0f) return s;
        s.wi = (float3)(-wo.x, -wo.y, wo.z);
        s.weight = c.bsdf.colour;
        s.pdf = 1.0f;
        s.delta = 1;
        return s;
    }
    if (c.glossy.x < 0.0f) {
        BsdfSample s = bsdf_sample(c.lobe, c.bsdf, wo, u1, u2);
        if (component_tinted(c, wo, s.wi)) s.weight *= c.tint;
        return s;
    }
    /* the Lambert + glossy sum: one lobe's direction, the sum's value over the mixture pdf */
    BsdfSample s = u1 < c.glossy_prob ? conductor_sample(wo, u2, (float3)(1.0f), c.glossy_alpha, SMITH_CORRELATED)
                                      : lambert_sample(wo, u2, c.bsdf.colour);
    if (!(s.pdf > 0.0f)) return no_sample();
    s.pdf = component_pdf(c, wo, s.wi);
    if (!(s.pdf > 0.0f)) return no_sample();
    s.weight = component_eval(c, wo, s.wi) / s.pdf;
    return s;
}

/* ---------------------------------------------------------------- lights */
INLINE float power_heuristic(float a, float b) {
    float a2 = a * a, b2 = b * b;
    return a2 + b2 > 0.0f ? a2 / (a2 + b2) : 0.0f;
}

/* 1 if nothing lies between the vertex and p + wi * dist (dist INF_T: to infinity), else 0. */
INLINE float visible(const PathScene *s, const Surface *f, float3 wi, float dist, Rng *rng, uint *visits) {
    float3 origin = offset_origin(f->p, f->p_err, dot3(wi, f->n_geo) >= 0.0f ? f->n_geo : -f->n_geo);
    Ray sr = make_ray(origin, wi);
    float t_max = dist == INF_T ? INF_T : norm(f->p + wi * dist - origin) * SHADOW_T_SHRINK;
#if ALPHA_TEST
    float opacity;
    return seen_hit(&s->geo, s->tex, sr, 0.0f, t_max, false, rng, &opacity, visits).id < 0 ? 1.0f : 0.0f;
#else
    return transmittance(&s->geo, sr, 0.0f, t_max, true, visits);
#endif
}

/* An area light's parallelogram along the ray: t in (0, t_max) or INF_T. */
INLINE float hit_parallelogram(Ray r, float3 corner, float3 a, float3 b, float t_max) {
    float3 n = cross3(a, b);
    float denom = dot3(n, r.d);
    if (denom == 0.0f) return INF_T;
    float t = dot3(n, corner - r.o) / denom;
    if (!(t > 0.0f && t < t_max)) return INF_T;
    float3 q = r.o + t * r.d - corner;
    float aa = dot3(a, a), bb = dot3(b, b), ab = dot3(a, b), qa = dot3(q, a), qb = dot3(q, b);
    float det = aa * bb - ab * ab;
    float u = (qa * bb - qb * ab) / det, v = (qb * aa - qa * ab) / det;
    return (u >= 0.0f && u <= 1.0f && v >= 0.0f && v <= 1.0f) ? t : INF_T;
}

/* The emitter index of u's place in the emitters' running sum of power (binary search). */
INLINE int pick_emitter(const PathScene *s, float u) {
    int lo = 0, hi = s->p.n_emitters - 1;
    while (lo < hi) {
        int mid = (lo + hi) / 2;
        if (u < s->emitters[mid].cdf) hi = mid;
        else lo = mid + 1;
    }
    return lo;
}

/* Emitted radiance of primitive `prim` at barycentrics (u, v) towards a ray that met its front (emission is
 * one-sided): kernels/surface.h's emission_of its material there. */
INLINE float3 emission_at(const PathScene *s, int prim, float u, float v) {
    __global const Material *gm = &s->geo.materials[s->geo.objects[s->geo.prim_object[prim]].material];
    float2 uv[2] = {(float2)(0.0f), (float2)(0.0f)};
    if (material_textured(gm)) surface_uvs(s->tex, prim, u, v, uv);
    return emission_of(s->tex, gm, uv);
}

/* The solid-angle density with which NEE picks emitter e's point seen at distance `dist`, cos_l
 * the cosine at the emitter. */
INLINE float emitter_pdf(const PathScene *s, int e, float dist, float cos_l) {
    __global const Emitter *em = &s->emitters[e];
    return cos_l > 0.0f ? em->prob * dist * dist / (em->area * cos_l) : 0.0f;
}

/* NEE to one light: the contribution (f cos Li / pdf, MIS-weighted where a BSDF ray could also find it). */
INLINE float3 light_sample(const PathScene *s, int li, const Surface *f, Component c, Frame fr, float3 wo, Rng *rng,
                           uint *visits, uint *rays) {
    __global const Light *L = &s->lights[li];
    float2 u = (float2)(rng_next(rng), rng_next(rng)); /* drawn for every light: fixed dimensions */
    float3 radiance = L->intensity * vload3(0, L->colour);
    bool physical = L->falloff == LIGHT_FALLOFF_INVERSE_SQUARE;
    float3 wi;
    float dist = INF_T, scale = physical ? 1.0f : M_PI_F, mis = 1.0f;
    if (L->type == LIGHT_DIRECTIONAL) {
        wi = -unit(vload3(0, L->direction));
    } else {
        float3 y = vload3(0, L->position);
        float3 ea = vload3(0, L->edge_a), eb = vload3(0, L->edge_b);
        if (L->type == LIGHT_AREA) y += u.x * ea + u.y * eb;
        float3 d = y - f->p;
        dist = norm(d);
        if (!(dist > 0.0f)) return (float3)(0.0f);
        wi = d / dist;
        if (physical && L->type == LIGHT_POINT) scale = 1.0f / (dist * dist);
        if (L->type == LIGHT_SPOT) scale = spot_profile(L, -wi) / (dist * dist); /* always physical */
        if (physical && L->type == LIGHT_AREA) { /* a two-sided emitter of radiance I c, sampled by area */
            float3 nl = cross3(ea, eb);
            float area = norm(nl);
            float cos_l = abs_f(dot3(nl, wi)) / area;
            float light_pdf = dist * dist / (area * cos_l);
            if (!(light_pdf < INFINITY)) return (float3)(0.0f);
            scale = 1.0f / light_pdf;
            mis = power_heuristic(light_pdf, component_pdf(c, wo, to_local(fr, wi)));
            if (!AREA_NEE) return (float3)(0.0f);
            if (!AREA_BSDF) mis = 1.0f;
        }
    }
    float3 fc = component_eval(c, wo, to_local(fr, wi));
    if (!(max3(fc) > 0.0f)) return (float3)(0.0f);
    *rays += 1;
    return fc * radiance * (scale * mis * visible(s, f, wi, dist, rng, visits));
}

/* The MIS-weighted NEE estimate f cos Le / pdf of radiance le arriving along wi from a point drawn with
 * solid-angle density light_pdf, dist away (INF_T: from infinity), weighted against the component's own
 * sampling of wi by the power heuristic: the tail emitter, map and environment sampling share. */
INLINE float3 nee_weighted(const PathScene *s, const Surface *f, Component c, Frame fr, float3 wo, float3 wi, float3 le,
                           float light_pdf, float dist, Rng *rng, uint *visits, uint *rays) {
    float3 wl = to_local(fr, wi);
    float3 fc = component_eval(c, wo, wl);
    if (!(max3(fc) > 0.0f)) return (float3)(0.0f);
    float mis = power_heuristic(light_pdf, component_pdf(c, wo, wl));
    *rays += 1;
    return fc * le * (mis / light_pdf * visible(s, f, wi, dist, rng, visits));
}

/* NEE to one point of one emissive triangle, chosen in proportion to its power. */
INLINE float3 emitter_sample(const PathScene *s, const Surface *f, Component c, Frame fr, float3 wo, Rng *rng,
                             uint *visits, uint *rays) {
    float pick = rng_next(rng);
    float2 u = (float2)(rng_next(rng), rng_next(rng));
    if (s->p.n_emitters == 0) return (float3)(0.0f);
    int e = pick_emitter(s, pick);
    __global const Emitter *em = &s->emitters[e];
    float3 v0 = vload3(0, em->v0), v1 = vload3(0, em->v1), v2 = vload3(0, em->v2);
    float su = sqrt(u.x); /* uniform on the triangle: (1 - su, su (1 - v), su v) */
    float3 y = (1.0f - su) * v0 + su * (1.0f - u.y) * v1 + su * u.y * v2;
    float3 d = y - f->p;
    float dist = norm(d);
    if (!(dist > 0.0f)) return (float3)(0.0f);
    float3 wi = d / dist;
    float cos_l = -dot3(unit(cross3(v1 - v0, v2 - v0)), wi);
    float light_pdf = emitter_pdf(s, e, dist, cos_l);
    if (!(light_pdf > 0.0f && light_pdf < INFINITY)) return (float3)(0.0f);
    float3 le = emission_at(s, em->prim, su * (1.0f - u.y), su * u.y);
    return nee_weighted(s, f, c, fr, wo, wi, le, light_pdf, dist, rng, visits, rays);
}

/* NEE to an environment map: a direction drawn by the map's luminance (envmap.h). */
INLINE float3 env_map_sample(const PathScene *s, const Surface *f, Component c, Frame fr, float3 wo, float2 u,
                             Rng *rng, uint *visits, uint *rays) {
    if (!ENV_NEE || !s->env.m.sampled) return (float3)(0.0f);
    float3 le;
    float env_pdf;
    float3 wi = env_sample(&s->env, u, &le, &env_pdf);
    if (!(env_pdf > 0.0f && env_pdf < INFINITY)) return (float3)(0.0f);
#if !ENV_BSDF
    *rays += 1;
    return component_eval(c, wo, to_local(fr, wi)) * le * (visible(s, f, wi, INF_T, rng, visits) / env_pdf);
#endif
    return nee_weighted(s, f, c, fr, wo, wi, le, env_pdf, INF_T, rng, visits, rays);
}

/* NEE to the environment: the map's own sampling, or for the constant environment a cosine-weighted
 * direction about the shading normal. */
INLINE float3 environment_sample(const PathScene *s, const Surface *f, Component c, Frame fr, float3 wo, Rng *rng,
                                 uint *visits, uint *rays) {
    float2 u = (float2)(rng_next(rng), rng_next(rng));
    if (s->env.m.width > 0) return env_map_sample(s, f, c, fr, wo, u, rng, visits, rays);
    float3 env = vload3(0, s->p.environment);
    if (!(max3(env) > 0.0f)) return (float3)(0.0f);
    Frame nf = make_frame(f->n_shade);
    float3 wi = to_world(nf, cosine_hemisphere(u));
    float env_pdf = dot3(wi, f->n_shade) * M_1_PI_F;
    if (!(env_pdf > 0.0f)) return (float3)(0.0f);
    return nee_weighted(s, f, c, fr, wo, wi, env, env_pdf, INF_T, rng, visits, rays);
}

/* Every NEE strategy at a vertex whose component is not a delta lobe. */
INLINE float3 direct_lighting(const PathScene *s, const Surface *f, Component c, Frame fr, float3 wo, Rng *rng,
                              uint *visits, uint *rays) {
    float3 sum = (float3)(0.0f);
    rng_slot(rng, SLOT_LIGHTS);
    for (int li = 0; li < s->p.frame.n_lights; ++li) sum += light_sample(s, li, f, c, fr, wo, rng, visits, rays);
    rng_slot(rng, SLOT_EMITTER);
    sum += emitter_sample(s, f, c, fr, wo, rng, visits, rays);
    rng_slot(rng, SLOT_ENV);
    sum += environment_sample(s, f, c, fr, wo, rng, visits, rays);
    return sum;
}

/* What a BSDF-sampled ray (or the camera ray: prev_pdf 0, prev_delta) finds of the physical area
 * lights before distance t_max: their radiance, MIS-weighted against their NEE. */
INLINE float3 area_lights_on_ray(const PathScene *s, Ray r, float t_max, bool prev_delta, float prev_pdf) {
    float3 sum = (float3)(0.0f);
    for (int li = 0; li < s->p.frame.n_lights; ++li) {
        __global const Light *L = &s->lights[li];
        if (L->type != LIGHT_AREA || L->falloff != LIGHT_FALLOFF_INVERSE_SQUARE) continue;
        float3 ea = vload3(0, L->edge_a), eb = vload3(0, L->edge_b);
        float t = hit_parallelogram(r, vload3(0, L->position), ea, eb, t_max);
        if (t == INF_T || (!AREA_BSDF && !prev_delta)) continue;
        float3 nl = cross3(ea, eb); /* |nl| is the area */
        float mis = prev_delta || !AREA_NEE ? 1.0f : power_heuristic(prev_pdf, t * t / abs_f(dot3(nl, r.d))); /* dist^2 / (A cos) */
        sum += mis * L->intensity * vload3(0, L->colour);
    }
    return sum;
}

/* Emission met by a ray at surface f (hit h at distance h.t from the previous vertex): the material's
 * radiance on front faces, MIS-weighted against NEE when the previous lobe was not a delta. */
INLINE float3 emission_met(const PathScene *s, const Surface *f, const MaterialPoint *m, Hit h, float3 d, bool prev_delta,
                          float prev_pdf) {
    float3 le = m->emission;
    if (!f->front || !(max3(le) > 0.0f)) return (float3)(0.0f);
    int e = s->emitter_of_prim[h.id];
    if (prev_delta || e < 0) return le; /* spheres emit but are not sampled: only BSDF rays find them */
    return le * power_heuristic(prev_pdf, emitter_pdf(s, e, h.t, dot3(f->n_geo, -d)));
}

/* What a ray that meets nothing brings back: the environment's radiance towards -d, and in *mis its weight
 * against the environment's NEE when the previous lobe was not a delta (prev_n: the previous vertex's shading normal). */
INLINE float3 environment_met(const PathScene *s, float3 d, float3 prev_n, bool prev_delta, float prev_pdf, float *mis) {
    float env_pdf;
    float3 le;
    if (s->env.m.width > 0) {
        le = env_eval(&s->env, d, &env_pdf);
        if (!ENV_NEE) env_pdf = 0.0f;
        if (!ENV_BSDF && !prev_delta) le = (float3)(0.0f);
    } else {
        env_pdf = max_f(dot3(prev_n, d), 0.0f) * M_1_PI_F;
        le = vload3(0, s->p.environment);
    }
    *mis = prev_delta ? 1.0f : power_heuristic(prev_pdf, env_pdf);
    return le;
}

/* The component's local frame: +z on the ray's side for reflection, outward for dielectrics (bsdf.h's eta). */
INLINE Frame component_frame(Component c, const Surface *f) {
    bool dielectric = c.lobe == BSDF_DIELECTRIC || c.lobe == BSDF_ROUGH_DIELECTRIC;
    return make_frame(dielectric && !f->front ? -f->n_shade : f->n_shade);
}

/* What a path's first hit tells the AOVs: the unit shading normal, the distance, the albedo (the base colour or
 * kd, times glTF's occlusion) and the object; zeros and -1 on a miss. */
typedef struct {
    float3 normal, albedo;
    float depth;
    int object;
} FirstHit;

INLINE FirstHit first_hit_of(const PathScene *s, const Surface *f, const MaterialPoint *m, Hit h) {
    FirstHit fh = {(float3)(0.0f), (float3)(0.0f), 0.0f, -1};
    if (h.id < 0) return fh;
    fh.object = hit_object(&s->geo, h);
    fh.normal = f->n_shade;
    fh.depth = h.t;
    fh.albedo = (m->model == MATERIAL_MODEL_GLTF ? m->base_color : m->kd) * m->occlusion;
    return fh;
}

/* Radiance along one camera ray; *first gets its first hit. */
INLINE float3 path_radiance(const PathScene *s, Ray r, Rng *rng, FirstHit *first, uint *visits, uint *rays) {
    float3 radiance = (float3)(0.0f), beta = (float3)(1.0f), prev_n = (float3)(0.0f);
    float prev_pdf = 0.0f;
    bool prev_delta = true; /* the camera ray: every light it meets counts whole */
    float t_min = 0.0f;
#if HIDE_EMITTERS
    int hidden = 0;
#endif
    for (int depth = 0;; ++depth) {
        float opacity;
        Hit h = seen_hit(&s->geo, s->tex, r, t_min, INF_T, depth == 0, rng, &opacity, visits);
        *rays += 1;
#if HIDE_EMITTERS
        if (depth == 0 && h.id >= 0 && s->emitter_of_prim[h.id] >= 0 && ++hidden < HIDDEN_LAYERS) {
            t_min = h.t; /* the camera ray again, past this emitting triangle */
            depth = -1;
            continue;
        }
        t_min = 0.0f;
#endif
        bool shown = !HIDE_EMITTERS || depth > 0; /* emission this vertex may add */
        if (shown) radiance += beta * area_lights_on_ray(s, r, h.t, prev_delta, prev_pdf);
        if (h.id < 0) {
            float mis;
            float3 le = environment_met(s, r.d, prev_n, prev_delta, prev_pdf, &mis);
            if (shown) radiance += beta * le * mis;
            if (depth == 0) *first = first_hit_of(s, 0, 0, h);
            break;
        }
        Surface f = surface_at(&s->geo, s->normals, s->tex, h, r.o, r.d);
        MaterialPoint m = material_at(s->tex, s->geo.materials, &f);
        if (depth == 0) *first = first_hit_of(s, &f, &m, h);
        if (shown) radiance += beta * emission_met(s, &f, &m, h, r.d, prev_delta, prev_pdf);
        if (depth > s->p.frame.max_depth) break; /* the last vertex: only its emission counts */
        rng_vertex(rng, depth); /* this vertex's dimensions (sobol.h) */
        Component c = pick_component(&m, rng_next(rng));
        Frame fr = component_frame(c, &f);
        float3 wo = to_local(fr, -r.d);
        if (!component_is_delta(c)) radiance += beta * direct_lighting(s, &f, c, fr, wo, rng, visits, rays);
        rng_slot(rng, SLOT_BSDF);
        float u1 = rng_next(rng);
        float2 u2 = (float2)(rng_next(rng), rng_next(rng));
        BsdfSample bs = component_sample(c, wo, u1, u2);
        if (!(bs.pdf > 0.0f)) break;
        float3 wi = to_world(fr, bs.wi);
        beta *= bs.weight;
        if (depth >= RR_DEPTH) { /* Russian roulette: continue with probability q, weighted by 1 / q */
            float q = min_f(max3(beta), RR_SURVIVE_MAX);
            rng_slot(rng, SLOT_RR);
            if (!(rng_next(rng) < q)) break;
            beta /= q;
        }
        /* ends a path of no throughput, or a NaN or runaway one: reflectances <= 1 keep beta near 1, and
         * BETA_LIMIT times the largest radiance a scene allows (1e12) stays inside float32 */
        if (!(max3(beta) > 0.0f && max3(beta) < BETA_LIMIT)) break;
        prev_delta = bs.delta != 0;
        prev_pdf = bs.pdf;
        prev_n = f.n_shade;
        r = make_ray(offset_origin(f.p, f.p_err, dot3(wi, f.n_geo) >= 0.0f ? f.n_geo : -f.n_geo), wi);
    }
    return radiance;
}

/* A pixel's AOVs: the object id and depth of its first path, and the normal and albedo as the colour is, the
 * filtered mean over its paths (a denoiser wants them filtered like the beauty; Mitsuba's film does the same). */
INLINE void record_aovs(FirstHit first, float3 normal, float3 albedo, __global AovRecord *aov, __global IdRecord *id) {
    id->path[0] = first.object; /* the rest stays -1: one id per pixel */
#if WRITE_AOV
    if (first.object >= 0 || max3(abs3(normal)) > 0.0f) { /* a miss in every path keeps the cleared record */
        vstore3(normal, 0, aov->normal);
        aov->depth = first.depth;
        vstore3(albedo, 0, aov->albedo);
    }
#endif
}

#if SPLAT_RADIUS
#define SPLAT_SIDE (2 * SPLAT_RADIUS + 1)
#define SPLAT_SLOTS (SPLAT_SIDE * SPLAT_SIDE)
/* A sample at `off` in its pixel, of radiance L, added to slot (dy, dx) as (f L, f), f the filter's weight about the
 * centre of the pixel dy - R rows and dx - R columns away (clrender/trace/film.py gathers the slots). */
INLINE void splat_sample(float4 *splats, float2 off, float3 L) {
    float wx[SPLAT_SIDE], wy[SPLAT_SIDE];
    for (int k = 0; k < SPLAT_SIDE; ++k) {
        wx[k] = film_weight(SPLAT_FILTER, off.x - 0.5f - (float)(k - SPLAT_RADIUS));
        wy[k] = film_weight(SPLAT_FILTER, off.y - 0.5f - (float)(k - SPLAT_RADIUS));
    }
    for (int dy = 0; dy < SPLAT_SIDE; ++dy)
        for (int dx = 0; dx < SPLAT_SIDE; ++dx) {
            float f = wy[dy] * wx[dx];
            splats[dy * SPLAT_SIDE + dx] += (float4)(f * L, f);
        }
}
#endif

/* Pixels `pixels[i]`: params.spp paths each, samples first_sample ... first_sample + spp - 1 of the pixel's
 * sequence (progressive passes continue it).  colour_out gets the filtered mean (and its weight), or with
 * SPLAT_RADIUS R > 0 the pixel's (2R + 1)^2 splat slots (splat_sample) at gid * SPLAT_SLOTS. */
__kernel void render_path(__global const TreeNode *nodes, __global const PrimSlot *prims, __global const int *prim_object,
                          __global const VertexNormals *normals, __global const VertexAttributes *attributes,
                          __global const float4 *texels, __global const char *tables, __global const char *world,
                          __global const int *pixels, PathParams params, __global char *out) {
    FrameParams frame = params.frame;
    int gid = get_global_id(0);
    if (gid >= frame.n_work) return;
    PathScene s;
    s.geo = scene_geometry(nodes, prims, prim_object, tables, frame.tables, frame.n_prims, frame.n_instances, true);
    s.normals = normals; s.lights = REGION(world, const Light, frame.world.lights);
    s.emitters = REGION(world, const Emitter, frame.world.emitters);
    s.emitter_of_prim = REGION(world, const int, frame.world.emitter_of_prim);
    s.env = env_view(frame.env_map, REGION(world, const float4, frame.world.env_texels), REGION(world, const float, frame.world.env_marginal),
                     REGION(world, const float, frame.world.env_conditional));
    s.tex = texture_view(attributes, REGION(tables, const Texture, frame.tables.textures), texels);
    s.p = params;
    __global float4 *colour_out = REGION(out, float4, frame.out.colour);
    __global IdRecord *ids_out = REGION(out, IdRecord, frame.out.ids);
    __global uint2 *stats_out = REGION(out, uint2, frame.out.stats);
    __global AovRecord *aov_out = REGION(out, AovRecord, frame.out.aov);
    Camera camera = frame.camera;
    int pixel = pixels[gid];
    float px = (float)(pixel % frame.width), py = (float)(pixel / frame.width);
    uint n = (uint)frame.samples_per_side, per_pass = n * n == (uint)params.spp ? n * n : 1u;
    float3 sum = (float3)(0.0f), normal_sum = (float3)(0.0f), albedo_sum = (float3)(0.0f);
    float weight_sum = 0.0f;
    uint visits = 0, rays = 0;
    FirstHit first;
#if SPLAT_RADIUS
    float4 splats[SPLAT_SLOTS];
    for (int k = 0; k < SPLAT_SLOTS; ++k) splats[k] = (float4)(0.0f);
#endif
    for (uint s_i = 0; s_i < (uint)params.spp; ++s_i) {
        uint sample = (uint)params.first_sample + s_i;
        Rng rng = make_rng(frame.seed, (uint)pixel, sample);
        float2 off = per_pass > 1u && !RNG_SOBOL ? pixel_sample_offset(frame.sampler, s_i, n, &rng)
                                   : pixel_sample_offset(SAMPLER_RANDOM, 0, 1, &rng);
        float sx = 2.0f * (px + off.x) / (float)frame.width - 1.0f;
        float sy = 1.0f - 2.0f * (py + off.y) / (float)frame.height;
        Ray r = camera_ray(&camera, sx, sy, &rng);
        float weight = pixel_filter_weight(frame.pixel_filter, off);
        FirstHit fh;
#if SPLAT_RADIUS
        splat_sample(splats, off, path_radiance(&s, r, &rng, &fh, &visits, &rays));
#else
        sum += weight * path_radiance(&s, r, &rng, &fh, &visits, &rays);
#endif
        weight_sum += weight;
        normal_sum += weight * fh.normal;
        albedo_sum += weight * fh.albedo;
        if (s_i == 0) first = fh;
    }
#if SPLAT_RADIUS
    for (int k = 0; k < SPLAT_SLOTS; ++k) colour_out[gid * SPLAT_SLOTS + k] = splats[k];
#else
    colour_out[gid] = (float4)(sum / weight_sum, weight_sum);
#endif
    if (frame.record) record_aovs(first, normal_sum / weight_sum, albedo_sum / weight_sum, aov_out + gid, ids_out + gid);
    stats_out[gid] = (uint2)(visits, rays);
}
