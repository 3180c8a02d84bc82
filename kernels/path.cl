/* Unidirectional path tracing (issue 25): one work-item per pixel, `spp` paths each.
 *
 * At every surface vertex the material picks ONE component at random with its own weight (the
 * stochastic mixture of pbrt-v4's MixMaterial: unbiased, and each component is then a plain BSDF of
 * kernels/bsdf.h), then
 *   - next-event estimation: ONE light picked mostly by its power (the host's LightChoice records,
 *     clrender/trace/light_choice.py: the scene's lights, the emissive triangles, the environment) or, for the near
 *     choice's share, a scene light by its irradiance at the vertex (pick_near), and one shadow
 *     ray to it: a point light's position, a point of an area light or emissive triangle, a direction of the
 *     environment (the constant one: cosine-weighted about the shading normal; an image map: by its luminance x
 *     solid angle, kernels/envmap.h), its estimate divided by the light's probability;
 *   - BSDF sampling for the next direction; a BSDF ray that reaches an area light, an emissive
 *     triangle or the environment adds its emission weighted against that light's strategy by the
 *     power heuristic, whose light density is the light's probability times its own density (delta lights
 *     and delta lobes get no MIS: only one strategy can find them);
 *   - Russian roulette from params.rr_depth bounces on.
 * Light units are docs/shading.md's.  Lights with falloff "none" (the unnormalised model) give
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
/* the lane type bsdf.h is written over: one path a work-item (LANES 1) */
#include "lanes.h"
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
/* pick_component: a material point's lobe, whose dispatch (component_eval ...) is in bsdf.h */
#include "material.h"
/* ALPHA_TEST, seen_hit: what rays look past */
#include "alpha.h"
#include "spot.h"
#include "light_choice.h"
/* the reconstruction filters of SPLAT_FILTER */
#include "film.h"

#ifndef HIDE_EMITTERS
#define HIDE_EMITTERS 0 /* 1: camera rays look past emitting triangles and see no area light or environment (Mitsuba's hide_emitters) */
#endif
#define HIDDEN_LAYERS 16 /* HIDE_EMITTERS: emitting triangles a camera ray looks past at most; the next one shows */
#define BETA_LIMIT 1e18f /* a path's throughput past this ends it (no pixel may be inf or NaN) */
#define RR_SURVIVE_MAX 0.95f /* a path continues with probability min(max throughput x eta_scale, this) */
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
    __global const LightChoice *choices;   /* NEE's light distribution: lights, emitters, environment (pick_light) */
    EnvView env;                           /* an environment map (env.m.width > 0) in place of p.environment */
    PathParams p;
} PathScene;

/* ---------------------------------------------------------------- lights */
INLINE float power_heuristic(float a, float b) {
    float a2 = a * a, b2 = b * b;
    return a2 + b2 > 0.0f ? a2 / (a2 + b2) : 0.0f;
}

/* NEE's shadow ray towards p + wi * dist (dist INF_T: to infinity), left in st for the schedule to trace (shadow_step):
 * 1, the factor the contribution takes when nothing blocks the ray (shadow_step adds it only then). */
INLINE float defer_shadow(PathState *st, const Surface *f, float3 wi, float dist) {
    float3 origin = offset_origin(f->p, f->p_err, dot3(wi, f->n_geo) >= 0.0f ? f->n_geo : -f->n_geo);
    vstore3(origin, 0, st->shadow_o);
    vstore3(wi, 0, st->shadow_d);
    st->shadow_t_max = dist == INF_T ? INF_T : norm(f->p + wi * dist - origin) * SHADOW_T_SHRINK;
    st->shadowed = 1;
    st->rays += 1;
    return 1.0f;
}

/* Whether st's shadow ray reaches its end: nothing opaque (with ALPHA_TEST: nothing kept, its draws from rng) in
 * between. */
INLINE bool shadow_unblocked(const PathScene *s, PathState *st, Rng *rng) {
    Ray sr = make_ray(vload3(0, st->shadow_o), vload3(0, st->shadow_d));
#if ALPHA_TEST
    float opacity;
    return seen_hit(&s->geo, s->tex, sr, 0.0f, st->shadow_t_max, false, rng, &opacity, &st->visits).id < 0;
#else
    return transmittance(&s->geo, sr, 0.0f, st->shadow_t_max, opaque_pass(), &st->visits) > 0.0f;
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

/* NEE's light choices: the scene's lights 0 .. n_lights - 1, the emissive triangles after them, the environment, and
 * last the near choice (a scene light picked by its nearness at the vertex, pick_near). */
INLINE int env_choice(const PathScene *s) { return s->p.frame.n_lights + s->p.n_emitters; }
INLINE int near_choice(const PathScene *s) { return env_choice(s) + 1; }

/* The choice of u's place in the lights' running sum of power (light_choice.h). */
INLINE int pick_light(const PathScene *s, float u) { return pick_light_of(s->choices, near_choice(s) + 1, u); }

/* Scene light li's unoccluded irradiance scale at x, the weight of the near choice: I / d^2 (a spot's times its profile
 * towards x), a directional light's I, pi I for falloff "none"; 0 for a physical area light (not in the near choice:
 * a BSDF ray that meets it is MIS-weighted by a probability that must not depend on where the ray left). */
INLINE float light_nearness(const PathScene *s, int li, float3 x) {
    __global const Light *L = &s->lights[li];
    float3 c = vload3(0, L->colour);
    float strength = L->intensity * (c.x + c.y + c.z) * (1.0f / 3.0f);
    bool physical = L->falloff == LIGHT_FALLOFF_INVERSE_SQUARE;
    if (L->type == LIGHT_AREA) return physical ? 0.0f : M_PI_F * strength;
    if (L->type == LIGHT_DIRECTIONAL) return physical ? strength : M_PI_F * strength;
    if (!physical && L->type == LIGHT_POINT) return M_PI_F * strength;
    float3 d = vload3(0, L->position) - x;
    float d2 = dot3(d, d);
    if (!(d2 > 0.0f)) return 0.0f;
    if (L->type == LIGHT_SPOT) strength *= spot_profile(L, -unit(d));
    return strength / d2;
}

/* The sum of light_nearness over the scene lights at x (0: the near choice finds none there). */
INLINE float nearness_total(const PathScene *s, float3 x) {
    float total = 0.0f;
    for (int li = 0; li < s->p.frame.n_lights; ++li) total += light_nearness(s, li, x);
    return total;
}

/* The near choice: the scene light of u's place in the running sum of nearness at x (total: nearness_total > 0). */
INLINE int pick_near(const PathScene *s, float3 x, float total, float u) {
    float target = u * total, sum = 0.0f;
    int last = 0;
    for (int li = 0; li < s->p.frame.n_lights; ++li) {
        float w = light_nearness(s, li, x);
        if (!(w > 0.0f)) continue;
        sum += w;
        last = li;
        if (target < sum) return li;
    }
    return last; /* u * total rounded up past the float32 sum */
}

/* Emitted radiance of primitive `prim` at barycentrics (u, v) towards a ray that met its front (emission is
 * one-sided): kernels/surface.h's emission_of its material there. */
INLINE float3 emission_at(const PathScene *s, int prim, float u, float v) {
    int mi = s->geo.objects[s->geo.prim_object[prim]].material;
    float2 uv[2] = {(float2)(0.0f), (float2)(0.0f)};
    if (material_textured(s->tex, mi)) surface_uvs(s->tex, prim, u, v, uv);
    return emission_of(s->tex, mi, uv);
}

/* The solid-angle density with which NEE picks emitter e's point seen at distance `dist`, cos_l
 * the cosine at the emitter: the emitter's choice probability times its area density. */
INLINE float emitter_pdf(const PathScene *s, int e, float dist, float cos_l) {
    __global const Emitter *em = &s->emitters[e];
    float chosen = s->choices[s->p.frame.n_lights + e].prob;
    return cos_l > 0.0f ? chosen * dist * dist / (em->area * cos_l) : 0.0f;
}

/* One light's sample for NEE, before the BSDF: each kind of light fills one (light_sample, emitter_sample,
 * environment_sample) and nee_estimate evaluates the BSDF for all of them at one place, so that code run in SIMD lanes
 * (kernels/wavefront.cl) holds one copy of the lobes' eval and pdf, not one per kind of light (docs/lanes.md). */
typedef struct {
    float3 wi, le;   /* towards the light; what arrives along wi (radiance, or a delta light's intensity) */
    float dist;      /* to the light's point (INF_T: from infinity) */
    float light_pdf; /* its solid-angle density, times the light's choice (mis or divide) */
    float scale;     /* without `divide`: the estimate's factor in place of 1 / light_pdf */
    bool found;      /* false: this sample adds nothing (and traces no shadow ray) */
    bool mis;        /* weight against the lobe's own sampling of wi by the power heuristic */
    bool divide;     /* the estimate is f le (mis / light_pdf), else f le (scale mis) */
    bool check;      /* no shadow ray where the lobe's value is 0 */
} LightSample;

INLINE LightSample no_light(void) {
    LightSample ls;
    ls.wi = ls.le = (float3)(0.0f);
    ls.dist = INF_T;
    ls.light_pdf = ls.scale = 0.0f;
    ls.found = ls.mis = ls.divide = false;
    ls.check = true;
    return ls;
}

/* A sample of le along wi drawn with density light_pdf, dist away, MIS-weighted against the lobe's sampling. */
INLINE LightSample weighted_light(float3 wi, float3 le, float light_pdf, float dist) {
    LightSample ls = no_light();
    ls.wi = wi; ls.le = le; ls.light_pdf = light_pdf; ls.dist = dist;
    ls.found = ls.mis = ls.divide = true;
    return ls;
}

/* NEE to scene light li, chosen with probability `chosen` (f cos Li / pdf, MIS-weighted where a BSDF ray could also
 * find it), u the light's 2-D sample. */
INLINE LightSample light_sample(const PathScene *s, int li, float chosen, float2 u, const Surface *f) {
    __global const Light *L = &s->lights[li];
    LightSample ls = no_light();
    ls.le = L->intensity * vload3(0, L->colour);
    bool physical = L->falloff == LIGHT_FALLOFF_INVERSE_SQUARE;
    float scale = physical ? 1.0f : M_PI_F;
    if (L->type == LIGHT_DIRECTIONAL) {
        ls.wi = -unit(vload3(0, L->direction));
    } else {
        float3 y = vload3(0, L->position);
        float3 ea = vload3(0, L->edge_a), eb = vload3(0, L->edge_b);
        if (L->type == LIGHT_AREA) y += u.x * ea + u.y * eb;
        float3 d = y - f->p;
        float dist = norm(d);
        if (!(dist > 0.0f)) return ls;
        ls.wi = d / dist;
        ls.dist = dist;
        if (physical && L->type == LIGHT_POINT) scale = 1.0f / (dist * dist);
        if (L->type == LIGHT_SPOT) scale = spot_profile(L, -ls.wi) / (dist * dist); /* always physical */
        if (physical && L->type == LIGHT_AREA) { /* a two-sided emitter of radiance I c, sampled by area */
            float3 nl = cross3(ea, eb);
            float area = norm(nl);
            float cos_l = abs_f(dot3(nl, ls.wi)) / area;
            float light_pdf = chosen * dist * dist / (area * cos_l);
            if (!(light_pdf < INFINITY) || !AREA_NEE) return ls;
            ls.light_pdf = light_pdf;
            ls.scale = 1.0f / light_pdf; /* light_pdf holds the choice */
            ls.mis = AREA_BSDF;
            ls.found = true;
            return ls;
        }
    }
    ls.scale = scale / chosen;
    ls.found = true;
    return ls;
}

/* NEE to one point (u: uniform on the triangle) of emissive triangle e (emitter_pdf holds its choice probability). */
INLINE LightSample emitter_sample(const PathScene *s, int e, float2 u, const Surface *f) {
    __global const Emitter *em = &s->emitters[e];
    float3 v0 = vload3(0, em->v0), v1 = vload3(0, em->v1), v2 = vload3(0, em->v2);
    float su = sqrt(u.x); /* uniform on the triangle: (1 - su, su (1 - v), su v) */
    float3 y = (1.0f - su) * v0 + su * (1.0f - u.y) * v1 + su * u.y * v2;
    float3 d = y - f->p;
    float dist = norm(d);
    if (!(dist > 0.0f)) return no_light();
    float3 wi = d / dist;
    float cos_l = -dot3(unit(cross3(v1 - v0, v2 - v0)), wi);
    float light_pdf = emitter_pdf(s, e, dist, cos_l);
    if (!(light_pdf > 0.0f && light_pdf < INFINITY)) return no_light();
    float3 le = emission_at(s, em->prim, su * (1.0f - u.y), su * u.y);
    return weighted_light(wi, le, light_pdf, dist);
}

/* NEE to an environment map chosen with probability `chosen`: a direction drawn by the map's luminance (envmap.h). */
INLINE LightSample env_map_sample(const PathScene *s, float chosen, float2 u) {
    if (!ENV_NEE || !s->env.m.sampled) return no_light();
    float3 le;
    float env_pdf;
    float3 wi = env_sample(&s->env, u, &le, &env_pdf);
    env_pdf *= chosen;
    if (!(env_pdf > 0.0f && env_pdf < INFINITY)) return no_light();
    LightSample ls = weighted_light(wi, le, env_pdf, INF_T);
    ls.mis = ls.check = ENV_BSDF; /* !ENV_BSDF: f le / env_pdf, a shadow ray whatever f is */
    return ls;
}

/* NEE to the environment, chosen with probability `chosen`: the map's own sampling, or for the constant
 * environment a cosine-weighted direction about the shading normal. */
INLINE LightSample environment_sample(const PathScene *s, float chosen, float2 u, const Surface *f) {
    if (s->env.m.width > 0) return env_map_sample(s, chosen, u);
    float3 env = vload3(0, s->p.environment);
    if (!(max3(env) > 0.0f)) return no_light();
    Frame nf = make_frame(f->n_shade);
    float3 wi = to_world(nf, cosine_hemisphere(u));
    float env_pdf = chosen * dot3(wi, f->n_shade) * M_1_PI_F;
    if (!(env_pdf > 0.0f)) return no_light();
    return weighted_light(wi, env, env_pdf, INF_T);
}

/* The NEE estimate of light sample ls at surface f for component c (wo local): f cos Le times 1 / light_pdf or the
 * light's scale, MIS-weighted by the power heuristic where ls.mis, its shadow ray left in st. */
INLINE float3 nee_estimate(PathState *st, const Surface *f, Component c, Frame fr, V3 wo, LightSample ls) {
    if (!ls.found) return (float3)(0.0f);
    V3 wl = to_local(fr, ls.wi);
    float3 fc = component_eval(c, wo, wl);
    if (ls.check && !(max3(fc) > 0.0f)) return (float3)(0.0f);
    float mis = ls.mis ? power_heuristic(ls.light_pdf, component_pdf(c, wo, wl)) : 1.0f;
    float w = ls.divide ? mis / ls.light_pdf : ls.scale * mis;
    return fc * ls.le * (w * defer_shadow(st, f, ls.wi, ls.dist));
}

/* Next-event estimation at a vertex whose component is not a delta lobe: one light picked by power, one shadow ray.
 * Three random numbers at every such vertex, whichever light is picked: the pick, then the light's 2-D sample. */
INLINE float3 direct_lighting(const PathScene *s, const Surface *f, Component c, Frame fr, V3 wo, Rng *rng,
                              PathState *st) {
    rng_slot(rng, SLOT_LIGHT); /* the pick, then the light's 2-D sample as one pair */
    float pick = rng_next(rng);
    float2 u = rng_next2(rng);
    int k = pick_light(s, pick), n_lights = s->p.frame.n_lights;
    float chosen = s->choices[k].prob, near = s->choices[near_choice(s)].prob;
    if (!(chosen > 0.0f)) return (float3)(0.0f);
    LightSample ls;
    if (k < n_lights || k == near_choice(s)) { /* a scene light: by power, or by nearness; its probability is the sum */
        float total = near > 0.0f ? nearness_total(s, f->p) : 0.0f;
        if (k == near_choice(s)) {
            if (!(total > 0.0f)) return (float3)(0.0f); /* no light near: this share of the picks adds nothing */
            float below = s->choices[k].cdf - chosen;
            k = pick_near(s, f->p, total, min_f((pick - below) / chosen, 1.0f));
        }
        chosen = s->choices[k].prob + (total > 0.0f ? near * light_nearness(s, k, f->p) / total : 0.0f);
        ls = light_sample(s, k, chosen, u, f);
    } else {
        ls = k < env_choice(s) ? emitter_sample(s, k - n_lights, u, f) : environment_sample(s, chosen, u, f);
    }
    return nee_estimate(st, f, c, fr, wo, ls); /* one call site: one copy of the lobes' eval and pdf */
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
        float3 nl = cross3(ea, eb); /* |nl| is the area; NEE's density: the choice times dist^2 / (A cos) */
        float light_pdf = s->choices[li].prob * t * t / abs_f(dot3(nl, r.d));
        float mis = prev_delta || !AREA_NEE ? 1.0f : power_heuristic(prev_pdf, light_pdf);
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
 * against the environment's NEE when the previous lobe was not a delta (prev_n: the previous vertex's shading normal;
 * NEE's density: the environment's choice probability times its own). */
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
    env_pdf *= s->choices[env_choice(s)].prob;
    *mis = prev_delta ? 1.0f : power_heuristic(prev_pdf, env_pdf);
    return le;
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

/* ---------------------------------------------------------------- one path step, two schedules (docs/lanes.md)
 * A path in flight is a PathState record (clrender/layout.py).  Its steps, which render_path calls in a loop and
 * kernels/wavefront.cl as one kernel each: start_sample (the camera ray), extend_step (the closest hit: traversal),
 * shade_step (emission, NEE's shadow ray left in the record, the BSDF's next ray; no traversal), shadow_step (what the
 * shadow ray found) and finish_sample (the pixel's sums).  The rng is the path's, kept beside the record. */

/* The path's ray as the walks take it. */
INLINE Ray state_ray(const PathState *st) { return make_ray(vload3(0, st->o), vload3(0, st->d)); }

/* The pixel's sums, counters and first hit before its first sample. */
INLINE void start_pixel(PathState *st) {
    vstore3((float3)(0.0f), 0, st->sum);
    vstore3((float3)(0.0f), 0, st->normal_sum);
    vstore3((float3)(0.0f), 0, st->albedo_sum);
    st->weight_sum = 0.0f;
    st->first_object = -1;
    st->first_depth = 0.0f;
    st->visits = 0;
    st->rays = 0;
    st->shadowed = 0;
}

/* Sample s_i of this pass in pixel `pixel`: its rng, its position in the pixel and filter weight, its camera ray. */
INLINE void start_sample(const PathParams *p, PathState *st, int pixel, uint s_i, Rng *rng) {
    const FrameParams *frame = &p->frame;
    uint n = (uint)frame->samples_per_side, per_pass = n * n == (uint)p->spp ? n * n : 1u;
    *rng = make_rng(frame->seed, (uint)pixel, (uint)p->first_sample + s_i);
    bool grid = per_pass > 1u && !RNG_SOBOL; /* a stratified grid over one pass's samples, else uniform offsets */
    PixelSample ps = pixel_sample(frame, pixel, grid ? frame->sampler : SAMPLER_RANDOM, grid ? s_i : 0u, grid ? n : 1u, rng);
    Ray r = ps.ray;
    st->off[0] = ps.off.x;
    st->off[1] = ps.off.y;
    st->weight = ps.weight;
    st->pixel = pixel;
    st->sample = s_i;
    vstore3(r.o, 0, st->o);
    vstore3(r.d, 0, st->d);
    vstore3((float3)(1.0f), 0, st->beta);
    st->eta_scale = 1.0f;
    vstore3((float3)(0.0f), 0, st->radiance);
    vstore3((float3)(0.0f), 0, st->prev_n);
    st->prev_pdf = 0.0f;
    st->prev_delta = 1; /* the camera ray: every light it meets counts whole */
    st->depth = 0;
    st->ended = 0;
}

/* The closest hit of the path's ray (the camera ray with HIDE_EMITTERS: past up to HIDDEN_LAYERS emitting triangles). */
INLINE Hit extend_step(const PathScene *s, PathState *st, Rng *rng) {
    Ray r = state_ray(st);
    float t_min = 0.0f;
#if HIDE_EMITTERS
    int hidden = 0;
#endif
    for (;;) {
        float opacity;
        Hit h = seen_hit(&s->geo, s->tex, r, t_min, INF_T, st->depth == 0, rng, &opacity, &st->visits);
        st->rays += 1;
#if HIDE_EMITTERS
        if (st->depth == 0 && h.id >= 0 && s->emitter_of_prim[h.id] >= 0 && ++hidden < HIDDEN_LAYERS) {
            t_min = h.t; /* the camera ray again, past this emitting triangle */
            continue;
        }
#endif
        return h;
    }
}

/* What shade_step's two halves share of a vertex. */
typedef struct {
    Surface f;
    MaterialPoint m;
    Component c;
    Frame fr;
    V3 wo;
} PathVertex;

INLINE void set_first_hit(PathState *st, FirstHit fh) {
    vstore3(fh.normal, 0, st->fh_normal);
    vstore3(fh.albedo, 0, st->fh_albedo);
    st->fh_depth = fh.depth;
    st->fh_object = fh.object;
}

/* shade_step's first half at hit h: the light the ray brings (area lights, the environment or the surface's emission),
 * the first hit, and NEE's shadow ray with the radiance it adds if unblocked (st->shadowed, shadow_l, shadow_beta).  False: the path
 * ends here (a miss, or the vertex past max_depth). */
INLINE bool shade_surface(const PathScene *s, PathState *st, Hit h, Rng *rng, PathVertex *v) {
    Ray r = state_ray(st);
    float3 beta = vload3(0, st->beta), radiance = vload3(0, st->radiance);
    bool prev_delta = st->prev_delta != 0;
    float prev_pdf = st->prev_pdf;
    int depth = st->depth;
    st->shadowed = 0;
    bool shown = !HIDE_EMITTERS || depth > 0; /* emission this vertex may add */
    if (shown) radiance += beta * area_lights_on_ray(s, r, h.t, prev_delta, prev_pdf);
    if (h.id < 0) {
        float mis;
        float3 le = environment_met(s, r.d, vload3(0, st->prev_n), prev_delta, prev_pdf, &mis);
        if (shown) radiance += beta * le * mis;
        if (depth == 0) set_first_hit(st, first_hit_of(s, 0, 0, h));
        vstore3(radiance, 0, st->radiance);
        return false;
    }
    v->f = surface_at(&s->geo, s->normals, s->tex, h, r.o, r.d);
    v->m = material_at(s->tex, s->tex.materials, &v->f);
    if (depth == 0) set_first_hit(st, first_hit_of(s, &v->f, &v->m, h));
    if (shown) radiance += beta * emission_met(s, &v->f, &v->m, h, r.d, prev_delta, prev_pdf);
    vstore3(radiance, 0, st->radiance);
    if (depth > s->p.frame.max_depth) return false; /* the last vertex: only its emission counts */
    rng_vertex(rng, depth); /* this vertex's dimensions (sobol.h) */
    v->c = pick_component(&v->m, rng_next(rng));
    v->fr = component_frame(v->c, &v->f);
    v->wo = to_local(v->fr, -r.d);
    if (!component_is_delta(v->c)) {
        float3 nee = direct_lighting(s, &v->f, v->c, v->fr, v->wo, rng, st);
        if (st->shadowed) {
            vstore3(nee, 0, st->shadow_l);
            vstore3(beta, 0, st->shadow_beta);
        }
    }
    return true;
}

/* shade_step's second half: the BSDF's next direction, Russian roulette, and the next ray.  False: the path ends. */
INLINE bool scatter(const PathScene *s, PathState *st, const PathVertex *v, Rng *rng) {
    rng_slot(rng, SLOT_BSDF);
    float u1 = rng_next(rng);
    float2 u2 = rng_next2(rng);
    BsdfSample bs = component_sample(v->c, v->wo, u1, u2);
    if (!(bs.pdf > 0.0f)) return false;
    float3 wi = to_world(v->fr, bs.wi);
    float3 beta = vload3(0, st->beta) * bs.weight;
    st->eta_scale *= bs.eta * bs.eta; /* beta * eta_scale: the throughput without refraction's 1 / eta^2 */
    if (st->depth >= s->p.rr_depth) { /* Russian roulette: continue with probability q, weighted by 1 / q */
        float q = min_f(max3(beta) * st->eta_scale, RR_SURVIVE_MAX);
        rng_slot(rng, SLOT_RR);
        if (!(rng_next(rng) < q)) return false;
        beta /= q;
    }
    /* ends a path of no throughput, or a NaN or runaway one: reflectances <= 1 keep beta near 1, and
     * BETA_LIMIT times the largest radiance a scene allows (1e12) stays inside float32 */
    if (!(max3(beta) > 0.0f && max3(beta) < BETA_LIMIT)) return false;
    const Surface *f = &v->f;
    vstore3(beta, 0, st->beta);
    st->prev_delta = bs.delta != 0;
    st->prev_pdf = bs.pdf;
    vstore3(f->n_shade, 0, st->prev_n);
    vstore3(offset_origin(f->p, f->p_err, dot3(wi, f->n_geo) >= 0.0f ? f->n_geo : -f->n_geo), 0, st->o);
    vstore3(wi, 0, st->d);
    st->depth += 1;
    return true;
}

/* One vertex, NEE's shadow ray left untraced: false when the path ends (after that shadow ray). */
INLINE bool shade_step(const PathScene *s, PathState *st, Hit h, Rng *rng) {
    PathVertex v;
    return shade_surface(s, st, h, rng, &v) && scatter(s, st, &v, rng);
}

/* The shadow ray's answer: its radiance added when nothing blocked it (visible() multiplied it by exactly 1 or 0). */
INLINE void shadow_step(PathState *st, bool unblocked) {
    /* one expression, as `radiance += beta * nee` was: FP_CONTRACT is on here (intersect.h), a fused multiply-add */
    if (st->shadowed && unblocked) vstore3(vload3(0, st->radiance) + vload3(0, st->shadow_beta) * vload3(0, st->shadow_l), 0, st->radiance);
    st->shadowed = 0;
}

/* The megakernel's path: the steps in turn, each shadow ray traced where NEE made it (before the BSDF's sample: with
 * ALPHA_TEST and the independent sampler, its draws come first in the stream). */
INLINE void trace_path(const PathScene *s, PathState *st, Rng *rng) {
    for (;;) {
        Hit h = extend_step(s, st, rng);
        PathVertex v;
        bool on = shade_surface(s, st, h, rng, &v);
        if (st->shadowed) shadow_step(st, shadow_unblocked(s, st, rng));
        if (!on || !scatter(s, st, &v, rng)) return;
    }
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

#define SPLAT_SIDE (2 * SPLAT_RADIUS + 1)
#define SPLAT_SLOTS (SPLAT_SIDE * SPLAT_SIDE) /* 1 without SPLAT_RADIUS */
#if SPLAT_RADIUS
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

/* The sample's radiance and first hit into the pixel's sums (the first sample's hit is the pixel's id and depth); with
 * SPLAT_RADIUS, its radiance splatted into `splats`. */
INLINE void finish_sample(PathState *st, float4 *splats) {
    float3 radiance = vload3(0, st->radiance);
    float weight = st->weight;
#if SPLAT_RADIUS
    splat_sample(splats, (float2)(st->off[0], st->off[1]), radiance);
#else
    vstore3(vload3(0, st->sum) + weight * radiance, 0, st->sum);
#endif
    st->weight_sum += weight;
    vstore3(vload3(0, st->normal_sum) + weight * vload3(0, st->fh_normal), 0, st->normal_sum);
    vstore3(vload3(0, st->albedo_sum) + weight * vload3(0, st->fh_albedo), 0, st->albedo_sum);
    if (st->sample == 0) {
        st->first_object = st->fh_object;
        st->first_depth = st->fh_depth;
    }
}

/* Slot gid's outputs once its pixel's samples are done: the filtered mean (without SPLAT_RADIUS; the splats are
 * written as they are), the AOVs and the counters. */
INLINE void write_pixel(const PathParams *p, const PathState *st, int gid, __global char *out) {
    const FrameParams *frame = &p->frame;
    float3 sum = vload3(0, st->sum);
    float weight_sum = st->weight_sum;
#if !SPLAT_RADIUS
    REGION(out, float4, frame->out.colour)[gid] = (float4)(sum / weight_sum, weight_sum);
#endif
    if (frame->record) {
        FirstHit first = {(float3)(0.0f), (float3)(0.0f), st->first_depth, st->first_object};
        record_aovs(first, vload3(0, st->normal_sum) / weight_sum, vload3(0, st->albedo_sum) / weight_sum,
                    REGION(out, AovRecord, frame->out.aov) + gid, REGION(out, IdRecord, frame->out.ids) + gid);
    }
    REGION(out, uint2, frame->out.stats)[gid] = (uint2)(st->visits, st->rays);
}

/* The scene as every path kernel sees it (render_path, kernels/wavefront.cl). */
INLINE PathScene path_scene(__global const TreeNode *nodes, __global const PrimSlot *prims, __global const int *prim_object,
                            __global const VertexNormals *normals, __global const VertexAttributes *attributes,
                            __global const float4 *texels, __global const char *tables, __global const char *world,
                            PathParams params) {
    FrameParams frame = params.frame;
    PathScene s;
    s.geo = scene_geometry(nodes, prims, prim_object, tables, frame.tables, frame.n_prims, frame.n_instances, true);
    s.normals = normals; s.lights = REGION(world, const Light, frame.world.lights);
    s.emitters = REGION(world, const Emitter, frame.world.emitters);
    s.emitter_of_prim = REGION(world, const int, frame.world.emitter_of_prim);
    s.choices = REGION(world, const LightChoice, frame.world.light_choices);
    s.env = env_view(frame.env_map, REGION(world, const float4, frame.world.env_texels), REGION(world, const float, frame.world.env_marginal),
                     REGION(world, const float, frame.world.env_conditional), REGION(world, const int, frame.world.env_guides));
    s.tex = scene_textures(attributes, tables, frame.tables, texels);
    s.p = params;
    return s;
}

#ifndef PATH_STEPS_ONLY
/* Pixels `pixels[i]`: params.spp paths each, samples first_sample ... first_sample + spp - 1 of the pixel's
 * sequence (progressive passes continue it).  colour_out gets the filtered mean (and its weight), or with
 * SPLAT_RADIUS R > 0 the pixel's (2R + 1)^2 splat slots (splat_sample) at gid * SPLAT_SLOTS.  The megakernel schedule:
 * one path after another per work-item (kernels/wavefront.cl is the other). */
__kernel void render_path(__global const TreeNode *nodes, __global const PrimSlot *prims, __global const int *prim_object,
                          __global const VertexNormals *normals, __global const VertexAttributes *attributes,
                          __global const float4 *texels, __global const char *tables, __global const char *world,
                          __global const int *pixels, PathParams params, __global char *out) {
    int gid = get_global_id(0);
    if (gid >= params.frame.n_work) return;
    PathScene s = path_scene(nodes, prims, prim_object, normals, attributes, texels, tables, world, params);
    int pixel = pixels[gid];
    PathState st;
    start_pixel(&st);
    float4 splats[SPLAT_SLOTS];
#if SPLAT_RADIUS
    for (int k = 0; k < SPLAT_SLOTS; ++k) splats[k] = (float4)(0.0f);
#endif
    for (uint s_i = 0; s_i < (uint)params.spp; ++s_i) {
        Rng rng;
        start_sample(&params, &st, pixel, s_i, &rng);
        trace_path(&s, &st, &rng);
        finish_sample(&st, splats);
    }
#if SPLAT_RADIUS
    __global float4 *colour_out = REGION(out, float4, params.frame.out.colour);
    for (int k = 0; k < SPLAT_SLOTS; ++k) colour_out[gid * SPLAT_SLOTS + k] = splats[k];
#endif
    write_pixel(&params, &st, gid, out);
}
#endif
