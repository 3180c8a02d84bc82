/* Unidirectional path tracing (issue 25): one work-item per pixel, `spp` paths each (render_path), or with LANES 16 (8)
 * that many pixels a work-item, each in a lane of a vector register (render_path_lanes: the same steps over
 * kernels/lanes.h's lane type; docs/lanes.md).
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

/* ---------------------------------------------------------------- the path's state, in lanes (kernels/lanes.h)
 * One path's PathState record (clrender/layout.py) at width 1, as the megakernel and the wavefront keep it; in lanes a
 * record of lane fields under the same names (render_path_lanes).  GET3 reads a 3-vector field; PUT and PUT3 write a
 * field in the lanes of a mask (at width 1 the mask is the branch the step took: always set). */
#if LANES == 1
typedef PathState PathLanes;
#define GET3(st, f) vload3(0, (st)->f)
#define PUT3(st, f, v, on) vstore3((on) ? (v) : GET3(st, f), 0, (st)->f)
#else
typedef struct {
    V3 o, d, beta;
    LF eta_scale;
    V3 radiance, prev_n;
    LF prev_pdf;
    LI prev_delta, depth, live, ended, pixel;
    LU sample;
    LF off[2], weight;
    V3 fh_normal, fh_albedo;
    LF fh_depth;
    LI fh_object, shadowed;
    V3 shadow_o, shadow_d;
    LF shadow_t_max;
    V3 shadow_l, shadow_beta, sum;
    LF weight_sum;
    V3 normal_sum, albedo_sum;
    LI first_object;
    LF first_depth;
    LU visits, rays;
} PathLanes;
#define GET3(st, f) ((st)->f)
#define PUT3(st, f, v, on) ((st)->f = vpick((on), (v), (st)->f))
#endif
#define PUT(st, f, v, on) ((st)->f = (on) ? (v) : (st)->f)

/* acc + a b, each component one fused multiply-add (FP_CONTRACT is on here): what `acc += a * b` made of float3s */
INLINE V3 add_product(V3 acc, V3 a, V3 b) { return v3(acc.x + a.x * b.x, acc.y + a.y * b.y, acc.z + a.z * b.z); }

/* ---------------------------------------------------------------- lights */
INLINE LF power_heuristic(LF a, LF b) {
    LF a2 = a * a, b2 = b * b;
    return a2 + b2 > 0.0f ? a2 / (a2 + b2) : (LF)(0.0f);
}

/* NEE's shadow ray towards p + wi * dist (dist INF_T: to infinity), left in st's lanes `on` for the schedule to trace
 * (shadow_step): 1, the factor the contribution takes when nothing blocks the ray (shadow_step adds it only then). */
INLINE LF defer_shadow(PathLanes *st, const Surface *f, V3 wi, LF dist, LI on) {
    V3 origin = offset_origin(f->p, f->p_err, vpick(vdot(wi, f->n_geo) >= 0.0f, f->n_geo, vneg(f->n_geo)));
    V3 to = v3(f->p.x + wi.x * dist - origin.x, f->p.y + wi.y * dist - origin.y, f->p.z + wi.z * dist - origin.z);
    PUT3(st, shadow_o, origin, on);
    PUT3(st, shadow_d, wi, on);
    PUT(st, shadow_t_max, dist == INF_T ? (LF)(INF_T) : sqrt_l(vdot(to, to)) * SHADOW_T_SHRINK, on);
    PUT(st, shadowed, ALL_LANES, on);
    PUT(st, rays, st->rays + 1U, on);
    return 1.0f;
}

/* Whether shadow ray sr (make_ray's) reaches t_max: nothing opaque (with ALPHA_TEST: nothing kept, its draws from rng) in
 * between.  One ray: in lanes, each lane's in turn. */
INLINE bool ray_unblocked(const PathScene *s, Ray sr, float t_max, Rng *rng, uint *visits) {
#if ALPHA_TEST
    float opacity;
    return seen_hit(&s->geo, s->tex, sr, 0.0f, t_max, false, rng, &opacity, visits).id < 0;
#else
    return transmittance(&s->geo, sr, 0.0f, t_max, opaque_pass(), visits) > 0.0f;
#endif
}

/* An area light's parallelogram along the ray (o, d): t in (0, t_max) or INF_T. */
INLINE LF hit_parallelogram(V3 o, V3 d, float3 corner, float3 a, float3 b, LF t_max) {
    V3 n = splat3(cross3(a, b));
    LF denom = vdot(n, d);
    LF t = vdot(n, vsub(splat3(corner), o)) / denom;
    V3 q = v3(o.x + t * d.x - corner.x, o.y + t * d.y - corner.y, o.z + t * d.z - corner.z);
    float aa = dot3(a, a), bb = dot3(b, b), ab = dot3(a, b);
    LF qa = vdot(q, splat3(a)), qb = vdot(q, splat3(b));
    float det = aa * bb - ab * ab;
    LF u = (qa * bb - qb * ab) / det, v = (qb * aa - qa * ab) / det;
    LI inside = (denom != 0.0f) & (t > 0.0f) & (t < t_max) & (u >= 0.0f) & (u <= 1.0f) & (v >= 0.0f) & (v <= 1.0f);
    return inside ? t : (LF)(INF_T);
}

/* NEE's light choices: the scene's lights 0 .. n_lights - 1, the emissive triangles after them, the environment, and
 * last the near choice (a scene light picked by its nearness at the vertex, pick_near). */
INLINE int env_choice(const PathScene *s) { return s->p.frame.n_lights + s->p.n_emitters; }
INLINE int near_choice(const PathScene *s) { return env_choice(s) + 1; }

/* The choice of u's place in the lights' running sum of power (light_choice.h). */
INLINE LI pick_light(const PathScene *s, LF u) { return pick_light_of(s->choices, near_choice(s) + 1, u); }

/* Scene light li's unoccluded irradiance scale at x, the weight of the near choice: I / d^2 (a spot's times its profile
 * towards x), a directional light's I, pi I for falloff "none"; 0 for a physical area light (not in the near choice:
 * a BSDF ray that meets it is MIS-weighted by a probability that must not depend on where the ray left). */
INLINE LF light_nearness(const PathScene *s, LI li, V3 x) {
    __global const Light *L = s->lights;
    V3 c = FIELD3(L, li, colour);
    LF strength = FIELD_F(L, li, intensity) * (c.x + c.y + c.z) * (1.0f / 3.0f);
    LI physical = FIELD_I(L, li, falloff) == LIGHT_FALLOFF_INVERSE_SQUARE, type = FIELD_I(L, li, type);
    V3 d = vsub(FIELD3(L, li, position), x);
    LF d2 = vdot(d, d);
    LI spot = (type == LIGHT_SPOT) & (d2 > 0.0f);
    WHERE(spot, strength, strength * spot_profile(L, li, vneg(vunit(d))));
    LF near = d2 > 0.0f ? strength / d2 : (LF)(0.0f);
    near = NOT(physical) & (type == LIGHT_POINT) ? M_PI_F * strength : near;
    near = type == LIGHT_DIRECTIONAL ? (physical ? strength : M_PI_F * strength) : near;
    return type == LIGHT_AREA ? (physical ? (LF)(0.0f) : M_PI_F * strength) : near;
}

/* The sum of light_nearness over the scene lights at x (0: the near choice finds none there). */
INLINE LF nearness_total(const PathScene *s, V3 x) {
    LF total = 0.0f;
    for (int li = 0; li < s->p.frame.n_lights; ++li) total += light_nearness(s, li, x);
    return total;
}

/* The near choice: the scene light of u's place in the running sum of nearness at x (total: nearness_total > 0). */
INLINE LI pick_near(const PathScene *s, V3 x, LF total, LF u) {
    LF target = u * total, sum = 0.0f;
    LI last = 0, found = 0, pick = 0;
    for (int li = 0; li < s->p.frame.n_lights; ++li) {
        LF w = light_nearness(s, li, x);
        LI counted = NOT(found) & (w > 0.0f);
        sum = counted ? sum + w : sum;
        last = counted ? (LI)(li) : last;
        LI here = counted & (target < sum);
        pick = here ? (LI)(li) : pick;
        found |= here;
        if (ALL(found)) break;
    }
    return found ? pick : last; /* u * total rounded up past the float32 sum: the last */
}

/* Emitted radiance of primitive `prim` at barycentrics (u, v) towards a ray that met its front (emission is
 * one-sided): kernels/surface.h's emission_of its material there. */
INLINE V3 emission_at(const PathScene *s, LI prim, LF u, LF v) {
    LI mi = FIELD_I(s->geo.objects, gather_i(s->geo.prim_object, prim), material);
    V2 uv[2] = {v2(0.0f, 0.0f), v2(0.0f, 0.0f)};
    LI textured = material_textured(s->tex, mi);
    if (ANY(textured)) {
        V2 at[2];
        surface_uvs(s->tex, prim, u, v, at);
        uv[0] = pick2(textured, at[0], uv[0]);
        uv[1] = pick2(textured, at[1], uv[1]);
    }
    return emission_of(s->tex, mi, uv);
}

/* The solid-angle density with which NEE picks emitter e's point seen at distance `dist`, cos_l
 * the cosine at the emitter: the emitter's choice probability times its area density. */
INLINE LF emitter_pdf(const PathScene *s, LI e, LF dist, LF cos_l) {
    LF chosen = FIELD_F(s->choices, s->p.frame.n_lights + e, prob);
    return cos_l > 0.0f ? chosen * dist * dist / (FIELD_F(s->emitters, e, area) * cos_l) : (LF)(0.0f);
}

/* One light's sample for NEE, before the BSDF: each kind of light fills one (light_sample, emitter_sample,
 * environment_sample) and nee_estimate evaluates the BSDF for all of them at one place, so that code run in SIMD lanes
 * holds one copy of the lobes' eval and pdf, not one per kind of light (docs/lanes.md). */
typedef struct {
    V3 wi, le;       /* towards the light; what arrives along wi (radiance, or a delta light's intensity) */
    LF dist;         /* to the light's point (INF_T: from infinity) */
    LF light_pdf;    /* its solid-angle density, times the light's choice (mis or divide) */
    LF scale;        /* without `divide`: the estimate's factor in place of 1 / light_pdf */
    LI found;        /* false: this sample adds nothing (and traces no shadow ray) */
    LI mis;          /* weight against the lobe's own sampling of wi by the power heuristic */
    LI divide;       /* the estimate is f le (mis / light_pdf), else f le (scale mis) */
    LI check;        /* no shadow ray where the lobe's value is 0 */
} LightSample;

INLINE LightSample no_light(void) {
    LightSample ls;
    ls.wi = ls.le = v3_all(0.0f);
    ls.dist = INF_T;
    ls.light_pdf = ls.scale = 0.0f;
    ls.found = ls.mis = ls.divide = 0;
    ls.check = ALL_LANES;
    return ls;
}

/* a in the lanes of m, b in the others */
INLINE LightSample keep_light(LI m, LightSample a, LightSample b) {
    LightSample ls;
    ls.wi = vpick(m, a.wi, b.wi);
    ls.le = vpick(m, a.le, b.le);
    ls.dist = m ? a.dist : b.dist;
    ls.light_pdf = m ? a.light_pdf : b.light_pdf;
    ls.scale = m ? a.scale : b.scale;
    ls.found = m ? a.found : b.found;
    ls.mis = m ? a.mis : b.mis;
    ls.divide = m ? a.divide : b.divide;
    ls.check = m ? a.check : b.check;
    return ls;
}

/* A sample of le along wi drawn with density light_pdf, dist away, MIS-weighted against the lobe's sampling. */
INLINE LightSample weighted_light(V3 wi, V3 le, LF light_pdf, LF dist) {
    LightSample ls = no_light();
    ls.wi = wi; ls.le = le; ls.light_pdf = light_pdf; ls.dist = dist;
    ls.found = ls.mis = ls.divide = ALL_LANES;
    return ls;
}

/* NEE to scene light li, chosen with probability `chosen` (f cos Li / pdf, MIS-weighted where a BSDF ray could also
 * find it), u the light's 2-D sample. */
INLINE LightSample light_sample(const PathScene *s, LI li, LF chosen, V2 u, const Surface *f) {
    __global const Light *L = s->lights;
    LI type = FIELD_I(L, li, type), physical = FIELD_I(L, li, falloff) == LIGHT_FALLOFF_INVERSE_SQUARE;
    LI area = type == LIGHT_AREA, directional = type == LIGHT_DIRECTIONAL;
    LightSample ls = no_light();
    ls.le = vscale(FIELD_F(L, li, intensity), FIELD3(L, li, colour));
    V3 y = FIELD3(L, li, position), ea = FIELD3(L, li, edge_a), eb = FIELD3(L, li, edge_b);
    y = vpick(area, v3(y.x + (u.x * ea.x + u.y * eb.x), y.y + (u.x * ea.y + u.y * eb.y), y.z + (u.x * ea.z + u.y * eb.z)), y);
    V3 d = vsub(y, f->p);
    LF dist = sqrt_l(vdot(d, d));
    LI reached = directional | (dist > 0.0f);
    ls.wi = vpick(directional, vneg(vunit(FIELD3(L, li, direction))), vdiv(d, dist));
    ls.dist = directional ? (LF)(INF_T) : dist;
    LF scale = physical ? (LF)(1.0f) : (LF)(M_PI_F);
    scale = physical & (type == LIGHT_POINT) ? 1.0f / (dist * dist) : scale;
    WHERE(type == LIGHT_SPOT, scale, spot_profile(L, li, vneg(ls.wi)) / (dist * dist)); /* always physical */
    ls.scale = scale / chosen;
    ls.found = reached;
    LI physical_area = physical & area;
    if (ANY(physical_area)) { /* a two-sided emitter of radiance I c, sampled by area */
        V3 nl = vcross(ea, eb);
        LF size = sqrt_l(vdot(nl, nl));
        LF cos_l = abs_l(vdot(nl, ls.wi)) / size;
        LF light_pdf = chosen * dist * dist / (size * cos_l);
        LI sampled = physical_area & (light_pdf < INFINITY) & (AREA_NEE ? ALL_LANES : 0);
        ls.light_pdf = physical_area ? light_pdf : ls.light_pdf;
        ls.scale = physical_area ? 1.0f / light_pdf : ls.scale; /* light_pdf holds the choice */
        ls.mis = physical_area ? (AREA_BSDF ? ALL_LANES : 0) : ls.mis;
        ls.found = physical_area ? reached & sampled : ls.found;
    }
    return ls;
}

/* NEE to one point (u: uniform on the triangle) of emissive triangle e (emitter_pdf holds its choice probability). */
INLINE LightSample emitter_sample(const PathScene *s, LI e, V2 u, const Surface *f) {
    __global const Emitter *em = s->emitters;
    V3 v0 = FIELD3(em, e, v0), v1 = FIELD3(em, e, v1), v2 = FIELD3(em, e, v2);
    LF su = sqrt_l(u.x); /* uniform on the triangle: (1 - su, su (1 - v), su v) */
    LF a = su * (1.0f - u.y), b = su * u.y;
    V3 y = v3((1.0f - su) * v0.x + su * (1.0f - u.y) * v1.x + su * u.y * v2.x, (1.0f - su) * v0.y + su * (1.0f - u.y) * v1.y + su * u.y * v2.y,
              (1.0f - su) * v0.z + su * (1.0f - u.y) * v1.z + su * u.y * v2.z);
    V3 d = vsub(y, f->p);
    LF dist = sqrt_l(vdot(d, d));
    V3 wi = vdiv(d, dist);
    LF cos_l = -vdot(vunit(vcross(vsub(v1, v0), vsub(v2, v0))), wi);
    LF light_pdf = emitter_pdf(s, e, dist, cos_l);
    LI sampled = (dist > 0.0f) & (light_pdf > 0.0f) & (light_pdf < INFINITY);
    if (!ANY(sampled)) return no_light();
    V3 le = emission_at(s, FIELD_I(em, e, prim), a, b);
    return keep_light(sampled, weighted_light(wi, le, light_pdf, dist), no_light());
}

/* NEE to an environment map chosen with probability `chosen`: a direction drawn by the map's luminance (envmap.h). */
INLINE LightSample env_map_sample(const PathScene *s, LF chosen, V2 u) {
    if (!ENV_NEE || !s->env.m.sampled) return no_light();
    V3 le;
    LF env_pdf;
    V3 wi = env_sample(&s->env, u, &le, &env_pdf);
    env_pdf *= chosen;
    LightSample ls = weighted_light(wi, le, env_pdf, INF_T);
    ls.mis = ls.check = ENV_BSDF ? ALL_LANES : 0; /* !ENV_BSDF: f le / env_pdf, a shadow ray whatever f is */
    return keep_light((env_pdf > 0.0f) & (env_pdf < INFINITY), ls, no_light());
}

/* NEE to the environment, chosen with probability `chosen`: the map's own sampling, or for the constant
 * environment a cosine-weighted direction about the shading normal. */
INLINE LightSample environment_sample(const PathScene *s, LF chosen, V2 u, const Surface *f) {
    if (s->env.m.width > 0) return env_map_sample(s, chosen, u);
    float3 env = vload3(0, s->p.environment);
    if (!(max3(env) > 0.0f)) return no_light();
    Frame nf = make_frame(f->n_shade);
    V3 wi = to_world(nf, cosine_hemisphere(u));
    LF env_pdf = chosen * vdot(wi, f->n_shade) * M_1_PI_F;
    return keep_light(env_pdf > 0.0f, weighted_light(wi, splat3(env), env_pdf, INF_T), no_light());
}

/* The NEE estimate of light sample ls at surface f for component c (wo local), in the lanes `on`: f cos Le times
 * 1 / light_pdf or the light's scale, MIS-weighted by the power heuristic where ls.mis, its shadow ray left in st. */
INLINE V3 nee_estimate(PathLanes *st, const Surface *f, Component c, Frame fr, V3 wo, LightSample ls, LI on) {
    on &= ls.found;
    if (!ANY(on)) return v3_all(0.0f);
    V3 wl = to_local(fr, ls.wi);
    V3 fc = component_eval(c, wo, wl);
    on &= NOT(ls.check & NOT(max3_l(fc) > 0.0f));
    if (!ANY(on)) return v3_all(0.0f);
    LF mis = 1.0f;
    WHERE(ls.mis, mis, power_heuristic(ls.light_pdf, component_pdf(c, wo, wl)));
    LF w = ls.divide ? mis / ls.light_pdf : ls.scale * mis;
    return vpick(on, vscale(w * defer_shadow(st, f, ls.wi, ls.dist, on), vmul(fc, ls.le)), v3_all(0.0f));
}

/* Next-event estimation, in the lanes `on` (vertices whose component is not a delta lobe): one light picked by power,
 * one shadow ray.  Three random numbers at every such vertex, whichever light is picked: the pick, then the light's 2-D
 * sample.  In lanes each kind of light is a masked pass (the lights a lane's pick does not reach read record 0). */
INLINE V3 direct_lighting(const PathScene *s, const Surface *f, Component c, Frame fr, V3 wo, Rng *rng, PathLanes *st, LI on) {
    rng_slot(rng, SLOT_LIGHT); /* the pick, then the light's 2-D sample as one pair */
    LF pick = rng_next(rng);
    V2 u = rng_next2(rng);
    LI k = pick_light(s, pick);
    int n_lights = s->p.frame.n_lights;
    LF chosen = FIELD_F(s->choices, k, prob);
    float near = s->choices[near_choice(s)].prob;
    on &= chosen > 0.0f;
    LI scene_light = on & ((k < n_lights) | (k == near_choice(s)));
    LightSample ls = no_light();
    if (ANY(scene_light)) { /* a scene light: by power, or by nearness; its probability is the sum */
        LF total = near > 0.0f ? nearness_total(s, f->p) : (LF)(0.0f);
        LI by_nearness = scene_light & (k == near_choice(s));
        scene_light &= NOT(by_nearness & NOT(total > 0.0f)); /* no light near: this share of the picks adds nothing */
        by_nearness &= scene_light;
        if (ANY(by_nearness)) {
            LF below = FIELD_F(s->choices, k, cdf) - chosen;
            k = by_nearness ? pick_near(s, f->p, total, min_l((pick - below) / chosen, 1.0f)) : k;
        }
        LI li = scene_light ? k : (LI)(0);
        LF light_chosen = FIELD_F(s->choices, li, prob) + (total > 0.0f ? near * light_nearness(s, li, f->p) / total : (LF)(0.0f));
        ls = keep_light(scene_light, light_sample(s, li, light_chosen, u, f), ls);
    }
    LI emitter = on & NOT(scene_light) & (k >= n_lights) & (k < env_choice(s));
    if (ANY(emitter)) ls = keep_light(emitter, emitter_sample(s, emitter ? k - n_lights : (LI)(0), u, f), ls);
    LI environment = on & (k == env_choice(s));
    if (ANY(environment)) ls = keep_light(environment, environment_sample(s, chosen, u, f), ls);
    return nee_estimate(st, f, c, fr, wo, ls, scene_light | emitter | environment); /* one call site: one copy of the lobes */
}

/* What a BSDF-sampled ray (o, d) (or the camera ray: prev_pdf 0, prev_delta) finds of the physical area lights before
 * distance t_max: their radiance, MIS-weighted against their NEE. */
INLINE V3 area_lights_on_ray(const PathScene *s, V3 o, V3 d, LF t_max, LI prev_delta, LF prev_pdf) {
    V3 sum = v3_all(0.0f);
    for (int li = 0; li < s->p.frame.n_lights; ++li) {
        __global const Light *L = &s->lights[li];
        if (L->type != LIGHT_AREA || L->falloff != LIGHT_FALLOFF_INVERSE_SQUARE) continue;
        float3 ea = vload3(0, L->edge_a), eb = vload3(0, L->edge_b);
        LF t = hit_parallelogram(o, d, vload3(0, L->position), ea, eb, t_max);
        LI met = (t != INF_T) & (AREA_BSDF ? ALL_LANES : prev_delta);
        if (!ANY(met)) continue;
        float3 nl = cross3(ea, eb); /* |nl| is the area; NEE's density: the choice times dist^2 / (A cos) */
        LF light_pdf = s->choices[li].prob * t * t / abs_l(vdot(splat3(nl), d));
        LF mis = prev_delta | (AREA_NEE ? 0 : ALL_LANES) ? (LF)(1.0f) : power_heuristic(prev_pdf, light_pdf);
        float3 c = vload3(0, L->colour);
        float i = L->intensity;
        sum = vpick(met, v3(sum.x + mis * i * c.x, sum.y + mis * i * c.y, sum.z + mis * i * c.z), sum);
    }
    return sum;
}

/* The emitter record of each lane's hit in the lanes `on` (an emitting flat triangle's), else -1: instances never emit
 * (trace/instancing.py keeps emissive objects flat), and their primitive ids are past emitter_of_prim's. */
INLINE LI emitter_of(const PathScene *s, HitL h, LI on) {
    LI flat = on & (h.id >= 0) & NOT(placed(h));
#if LANES == 1
    return flat ? s->emitter_of_prim[h.id] : -1;
#else
    return flat ? gather_i(s->emitter_of_prim, flat ? h.id : (LI)(0)) : (LI)(-1);
#endif
}

/* Emission met by a ray along d at surface f (hit h at distance h.t from the previous vertex): the material's
 * radiance on front faces, MIS-weighted against NEE when the previous lobe was not a delta. */
INLINE V3 emission_met(const PathScene *s, const Surface *f, const MaterialPoint *m, HitL h, V3 d, LI prev_delta, LF prev_pdf) {
    V3 le = m->emission;
    LI shows = f->front & (max3_l(le) > 0.0f);
    if (!ANY(shows)) return v3_all(0.0f);
    LI e = emitter_of(s, h, shows);
    LI weighed = shows & NOT(prev_delta | (e < 0)); /* spheres emit but are not sampled: only BSDF rays find them */
    LF w = 1.0f;
    WHERE(weighed, w, power_heuristic(prev_pdf, emitter_pdf(s, max(e, (LI)(0)), h.t, vdot(f->n_geo, vneg(d)))));
    return vpick(shows, vpick(weighed, vscale(w, le), le), v3_all(0.0f));
}

/* What a ray along d that meets nothing brings back: the environment's radiance towards -d, and in *mis its weight
 * against the environment's NEE when the previous lobe was not a delta (prev_n: the previous vertex's shading normal;
 * NEE's density: the environment's choice probability times its own). */
INLINE V3 environment_met(const PathScene *s, V3 d, V3 prev_n, LI prev_delta, LF prev_pdf, LF *mis) {
    LF env_pdf;
    V3 le;
    if (s->env.m.width > 0) {
        le = env_eval(&s->env, d, &env_pdf);
        if (!ENV_NEE) env_pdf = 0.0f;
        if (!ENV_BSDF) le = vpick(prev_delta, le, v3_all(0.0f));
    } else {
        env_pdf = max_l(vdot(prev_n, d), 0.0f) * M_1_PI_F;
        le = splat3(vload3(0, s->p.environment));
    }
    env_pdf *= s->choices[env_choice(s)].prob;
    *mis = prev_delta ? (LF)(1.0f) : power_heuristic(prev_pdf, env_pdf);
    return le;
}

/* What a path's first hit tells the AOVs: the unit shading normal, the distance, the albedo (the base colour or
 * kd, times glTF's occlusion) and the object; zeros and -1 on a miss. */
typedef struct {
    V3 normal, albedo;
    LF depth;
    LI object;
} FirstHit;

INLINE FirstHit no_first_hit(void) {
    FirstHit fh = {v3_all(0.0f), v3_all(0.0f), 0.0f, -1};
    return fh;
}

INLINE FirstHit first_hit_of(const PathScene *s, const Surface *f, const MaterialPoint *m, HitL h) {
    FirstHit fh;
    fh.object = hit_object(&s->geo, h);
    fh.normal = f->n_shade;
    fh.depth = h.t;
    fh.albedo = vscale(m->occlusion, vpick(m->model == MATERIAL_MODEL_GLTF, m->base_color, m->kd));
    return fh;
}

/* ---------------------------------------------------------------- one path step, two schedules (docs/lanes.md)
 * A path in flight is a PathState record (clrender/layout.py).  Its steps, which render_path calls in a loop and
 * kernels/wavefront.cl as one kernel each: start_sample (the camera ray), extend_step (the closest hit: traversal),
 * shade_step (emission, NEE's shadow ray left in the record, the BSDF's next ray; no traversal), shadow_step (what the
 * shadow ray found) and finish_sample (the pixel's sums).  The rng is the path's, kept beside the record.  In lanes
 * (render_path_lanes), each step in the lanes of a mask `on`, the walks a lane at a time. */

/* The pixel's sums, counters and first hit before its first sample. */
INLINE void start_pixel(PathLanes *st) {
    PUT3(st, sum, v3_all(0.0f), ALL_LANES);
    PUT3(st, normal_sum, v3_all(0.0f), ALL_LANES);
    PUT3(st, albedo_sum, v3_all(0.0f), ALL_LANES);
    st->weight_sum = 0.0f;
    st->first_object = -1;
    st->first_depth = 0.0f;
    st->visits = 0;
    st->rays = 0;
    st->shadowed = 0;
}

/* Sample s_i of this pass in pixel `pixel`, in the lanes `on`: its rng, its position in the pixel and filter weight,
 * its camera ray. */
INLINE void start_sample(const PathParams *p, PathLanes *st, LI pixel, LU s_i, Rng *rng, LI on) {
    const FrameParams *frame = &p->frame;
    uint n = (uint)frame->samples_per_side, per_pass = n * n == (uint)p->spp ? n * n : 1u;
    Rng fresh = make_rng(frame->seed, AS_LU(pixel), (uint)p->first_sample + s_i);
    bool grid = per_pass > 1u && !RNG_SOBOL; /* a stratified grid over one pass's samples, else uniform offsets */
    PixelSample ps = pixel_sample(frame, pixel, grid ? frame->sampler : SAMPLER_RANDOM, grid ? s_i : (LU)(0u), grid ? n : 1u, &fresh);
#if LANES == 1
    *rng = fresh;
#else
    *rng = keep_rng(on, fresh, *rng);
#endif
    PUT(st, off[0], ps.off.x, on);
    PUT(st, off[1], ps.off.y, on);
    PUT(st, weight, ps.weight, on);
    PUT(st, pixel, pixel, on);
    PUT(st, sample, s_i, on);
    PUT3(st, o, ps.o, on);
    PUT3(st, d, ps.d, on);
    PUT3(st, beta, v3_all(1.0f), on);
    PUT(st, eta_scale, 1.0f, on);
    PUT3(st, radiance, v3_all(0.0f), on);
    PUT3(st, prev_n, v3_all(0.0f), on);
    PUT(st, prev_pdf, 0.0f, on);
    PUT(st, prev_delta, ALL_LANES, on); /* the camera ray: every light it meets counts whole */
    PUT(st, depth, 0, on);
    PUT(st, ended, 0, on);
}

#if LANES == 1
/* The closest hit of the path's ray (the camera ray with HIDE_EMITTERS: past up to HIDDEN_LAYERS emitting triangles),
 * each walk counted in st->rays (the lanes' loop is extend_lanes'). */
INLINE Hit extend_step(const PathScene *s, PathState *st, Rng *rng) {
    Ray r = make_ray(vload3(0, st->o), vload3(0, st->d));
    float t_min = 0.0f;
#if HIDE_EMITTERS
    int hidden = 0;
#endif
    for (;;) {
        float opacity;
        Hit h = seen_hit(&s->geo, s->tex, r, t_min, INF_T, st->depth == 0, rng, &opacity, &st->visits);
        st->rays += 1;
#if HIDE_EMITTERS
        if (st->depth == 0 && emitter_of(s, h, true) >= 0 && ++hidden < HIDDEN_LAYERS) {
            t_min = h.t; /* the camera ray again, past this emitting triangle */
            continue;
        }
#endif
        return h;
    }
}

/* Whether st's shadow ray reaches its end. */
INLINE bool shadow_unblocked(const PathScene *s, PathState *st, Rng *rng) {
    return ray_unblocked(s, make_ray(vload3(0, st->shadow_o), vload3(0, st->shadow_d)), st->shadow_t_max, rng, &st->visits);
}
#endif

INLINE void set_first_hit(PathLanes *st, FirstHit fh, LI on) {
    PUT3(st, fh_normal, fh.normal, on);
    PUT3(st, fh_albedo, fh.albedo, on);
    PUT(st, fh_depth, fh.depth, on);
    PUT(st, fh_object, fh.object, on);
}

/* What shade_step's two halves share of a vertex. */
typedef struct {
    Surface f;
    MaterialPoint m;
    Component c;
    Frame fr;
    V3 wo;
} PathVertex;

/* shade_step's first half at hit h, in the lanes `on`: the light the ray brings (area lights, the environment or the
 * surface's emission), the first hit, and NEE's shadow ray with the radiance it adds if unblocked (st->shadowed,
 * shadow_l, shadow_beta).  The lanes whose path goes on (false: a miss, or the vertex past max_depth). */
INLINE LI shade_surface(const PathScene *s, PathLanes *st, HitL h, Rng *rng, PathVertex *v, LI on) {
    V3 o = GET3(st, o), d = GET3(st, d), beta = GET3(st, beta), radiance = GET3(st, radiance);
    LI prev_delta = st->prev_delta != 0, depth = st->depth;
    LF prev_pdf = st->prev_pdf;
    PUT(st, shadowed, 0, on);
    LI shown = on & ((HIDE_EMITTERS ? 0 : ALL_LANES) | (depth > 0)); /* emission this vertex may add */
    if (ANY(shown)) radiance = vpick(shown, add_product(radiance, beta, area_lights_on_ray(s, o, d, h.t, prev_delta, prev_pdf)), radiance);
    LI miss = on & (h.id < 0), hit = on & NOT(miss);
    if (ANY(miss)) {
        LF mis;
        V3 le = environment_met(s, d, GET3(st, prev_n), prev_delta, prev_pdf, &mis);
        radiance = vpick(miss & shown, add_product(radiance, vmul(beta, le), v3(mis, mis, mis)), radiance);
        set_first_hit(st, no_first_hit(), miss & (depth == 0));
    }
    LI cont = hit & (depth <= s->p.frame.max_depth);
    if (ANY(hit)) {
#if LANES > 1 /* the other lanes (a miss, or no path) read primitive 0, and nothing keeps what they find */
        h.slot = hit ? h.slot : (LI)(0);
        h.id = hit ? h.id : (LI)(0);
#endif
        v->f = surface_at(&s->geo, s->normals, s->tex, h, o, d);
        v->m = material_at(s->tex, s->tex.materials, &v->f);
        set_first_hit(st, first_hit_of(s, &v->f, &v->m, h), hit & (depth == 0));
        radiance = vpick(hit & shown, add_product(radiance, beta, emission_met(s, &v->f, &v->m, h, d, prev_delta, prev_pdf)), radiance);
    }
    PUT3(st, radiance, radiance, on);
    if (!ANY(cont)) return cont; /* the last vertex: only its emission counts */
    rng_vertex(rng, depth); /* this vertex's dimensions (sobol.h) */
    v->c = pick_component(&v->m, rng_next(rng));
    v->fr = component_frame(v->c, &v->f);
    v->wo = to_local(v->fr, vneg(d));
    LI lit = cont & NOT(component_is_delta(v->c));
    if (ANY(lit)) {
        V3 nee = direct_lighting(s, &v->f, v->c, v->fr, v->wo, rng, st, lit);
        LI shadowed = lit & (st->shadowed != 0);
        PUT3(st, shadow_l, nee, shadowed);
        PUT3(st, shadow_beta, beta, shadowed);
    }
    return cont;
}

/* shade_step's second half, in the lanes `on`: the BSDF's next direction, Russian roulette, and the next ray.  The
 * lanes whose path goes on. */
INLINE LI scatter(const PathScene *s, PathLanes *st, const PathVertex *v, Rng *rng, LI on) {
    rng_slot(rng, SLOT_BSDF);
    LF u1 = rng_next(rng);
    V2 u2 = rng_next2(rng);
    BsdfSample bs = component_sample(v->c, v->wo, u1, u2);
    LI go = on & (bs.pdf > 0.0f);
    if (!ANY(go)) return go;
    V3 wi = to_world(v->fr, bs.wi);
    V3 beta = vmul(GET3(st, beta), bs.weight);
    PUT(st, eta_scale, st->eta_scale * (bs.eta * bs.eta), go); /* beta * eta_scale: the throughput without refraction's 1 / eta^2 */
    LI roulette = go & (st->depth >= s->p.rr_depth);
    if (ANY(roulette)) { /* Russian roulette: continue with probability q, weighted by 1 / q */
        LF q = min_l(max3_l(beta) * st->eta_scale, RR_SURVIVE_MAX);
        rng_slot(rng, SLOT_RR);
        go &= NOT(roulette) | (rng_next(rng) < q);
        beta = vpick(roulette, vdiv(beta, q), beta);
    }
    /* ends a path of no throughput, or a NaN or runaway one: reflectances <= 1 keep beta near 1, and
     * BETA_LIMIT times the largest radiance a scene allows (1e12) stays inside float32 */
    go &= (max3_l(beta) > 0.0f) & (max3_l(beta) < BETA_LIMIT);
    const Surface *f = &v->f;
    PUT3(st, beta, beta, go);
    PUT(st, prev_delta, bs.delta != 0, go);
    PUT(st, prev_pdf, bs.pdf, go);
    PUT3(st, prev_n, f->n_shade, go);
    PUT3(st, o, offset_origin(f->p, f->p_err, vpick(vdot(wi, f->n_geo) >= 0.0f, f->n_geo, vneg(f->n_geo))), go);
    PUT3(st, d, wi, go);
    PUT(st, depth, st->depth + 1, go);
    return go;
}

/* One vertex, NEE's shadow ray left untraced: false when the path ends (after that shadow ray). */
INLINE LI shade_step(const PathScene *s, PathLanes *st, HitL h, Rng *rng, LI on) {
    PathVertex v;
    on = shade_surface(s, st, h, rng, &v, on);
    return ANY(on) ? scatter(s, st, &v, rng, on) : on;
}

/* The shadow ray's answer in the lanes that have one: its radiance added where nothing blocked it (visible() multiplied
 * it by exactly 1 or 0). */
INLINE void shadow_step(PathLanes *st, LI unblocked) {
    LI add = (st->shadowed != 0) & unblocked;
    /* one expression, as `radiance += beta * nee` was: FP_CONTRACT is on here (intersect.h), a fused multiply-add */
    PUT3(st, radiance, add_product(GET3(st, radiance), GET3(st, shadow_beta), GET3(st, shadow_l)), add);
    st->shadowed = 0;
}

#if LANES == 1
/* The megakernel's path: the steps in turn, each shadow ray traced where NEE made it (before the BSDF's sample). */
INLINE void trace_path(const PathScene *s, PathState *st, Rng *rng) {
    for (;;) {
        Hit h = extend_step(s, st, rng);
        PathVertex v;
        bool on = shade_surface(s, st, h, rng, &v, true);
        if (st->shadowed) shadow_step(st, shadow_unblocked(s, st, rng));
        if (!on || !scatter(s, st, &v, rng, true)) return;
    }
}
#endif

#define SPLAT_SIDE (2 * SPLAT_RADIUS + 1)
#define SPLAT_SLOTS (SPLAT_SIDE * SPLAT_SIDE) /* 1 without SPLAT_RADIUS */
#if SPLAT_RADIUS
/* A sample at `off` in its pixel, of radiance L, added to slot (dy, dx) as (f L, f) in the lanes `on`, f the filter's
 * weight about the centre of the pixel dy - R rows and dx - R columns away (clrender/trace/film.py gathers the slots). */
INLINE void splat_sample(V4 *splats, V2 off, V3 L, LI on) {
    LF wx[SPLAT_SIDE], wy[SPLAT_SIDE];
    for (int k = 0; k < SPLAT_SIDE; ++k) {
        wx[k] = film_weight(SPLAT_FILTER, off.x - 0.5f - (float)(k - SPLAT_RADIUS));
        wy[k] = film_weight(SPLAT_FILTER, off.y - 0.5f - (float)(k - SPLAT_RADIUS));
    }
    for (int dy = 0; dy < SPLAT_SIDE; ++dy)
        for (int dx = 0; dx < SPLAT_SIDE; ++dx) {
            LF f = wy[dy] * wx[dx];
            V4 *slot = &splats[dy * SPLAT_SIDE + dx];
#if LANES == 1
            *slot += (float4)(f * L, f);
#else /* each product rounded before its sum, as the float4 above */
            LF r = f * L.x, g = f * L.y, b = f * L.z;
            *slot = v4(on ? slot->x + r : slot->x, on ? slot->y + g : slot->y, on ? slot->z + b : slot->z, on ? slot->w + f : slot->w);
#endif
        }
}
#endif

/* The sample's radiance and first hit into the pixel's sums, in the lanes `on` (the first sample's hit is the pixel's id
 * and depth); with SPLAT_RADIUS (one path a work-item), its radiance splatted into `splats`. */
INLINE void finish_sample(PathLanes *st, V4 *splats, LI on) {
    V3 radiance = GET3(st, radiance);
    LF weight = st->weight;
    V3 w = v3(weight, weight, weight);
#if SPLAT_RADIUS
    splat_sample(splats, v2(st->off[0], st->off[1]), radiance, on);
#else
    PUT3(st, sum, add_product(GET3(st, sum), w, radiance), on);
#endif
    PUT(st, weight_sum, st->weight_sum + weight, on);
    PUT3(st, normal_sum, add_product(GET3(st, normal_sum), w, GET3(st, fh_normal)), on);
    PUT3(st, albedo_sum, add_product(GET3(st, albedo_sum), w, GET3(st, fh_albedo)), on);
    LI first = on & (st->sample == 0U);
    PUT(st, first_object, st->fh_object, first);
    PUT(st, first_depth, st->fh_depth, first);
}

/* Slot gid's outputs once its pixel's samples are done: the filtered mean (without SPLAT_RADIUS; the splats are
 * written as they are), the AOVs (the first path's object and depth, the filtered means of the normal and
 * albedo) and the counters, from one pixel's sums. */
INLINE void write_pixel(const PathParams *p, int gid, __global char *out, float3 sum, float weight_sum, float3 normal_sum,
                        float3 albedo_sum, int first_object, float first_depth, uint visits, uint rays) {
    const FrameParams *frame = &p->frame;
#if !SPLAT_RADIUS
    REGION(out, float4, frame->out.colour)[gid] = (float4)(sum / weight_sum, weight_sum);
#endif
    if (frame->record) {
        float3 normal = normal_sum / weight_sum, albedo = albedo_sum / weight_sum;
        REGION(out, IdRecord, frame->out.ids)[gid].path[0] = first_object; /* the rest stays -1: one id per pixel */
#if WRITE_AOV
        __global AovRecord *aov = REGION(out, AovRecord, frame->out.aov) + gid;
        if (first_object >= 0 || max3(abs3(normal)) > 0.0f) { /* a miss in every path keeps the cleared record */
            vstore3(normal, 0, aov->normal);
            aov->depth = first_depth;
            vstore3(albedo, 0, aov->albedo);
        }
#endif
    }
    REGION(out, uint2, frame->out.stats)[gid] = (uint2)(visits, rays);
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

#if !defined(PATH_STEPS_ONLY) && LANES == 1
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
        start_sample(&params, &st, pixel, s_i, &rng, true);
        trace_path(&s, &st, &rng);
        finish_sample(&st, splats, true);
    }
#if SPLAT_RADIUS
    __global float4 *colour_out = REGION(out, float4, params.frame.out.colour);
    for (int k = 0; k < SPLAT_SLOTS; ++k) colour_out[gid * SPLAT_SLOTS + k] = splats[k];
#endif
    write_pixel(&params, gid, out, vload3(0, st.sum), st.weight_sum, vload3(0, st.normal_sum), vload3(0, st.albedo_sum), st.first_object,
                st.first_depth, st.visits, st.rays);
}
#endif

#if !defined(PATH_STEPS_ONLY) && LANES > 1
/* lane k of a 3-vector */
INLINE float3 lane3(V3 v, int k) { return (float3)(LANE(v.x, k), LANE(v.y, k), LANE(v.z, k)); }

/* no_hit in every lane */
INLINE HitL no_hits(void) {
    HitL h;
    h.t = INF_T; h.slot = h.id = -1; h.u = h.v = 0.0f;
#if INSTANCED
    h.instance = -1;
#endif
    return h;
}

/* The lanes' rays, each as make_ray makes it from (o, d), its 1/d and shear computed in lanes (the same operations:
 * the same bits), for the walks, which go one lane at a time: made one at a time, their six divisions were a twentieth
 * of the lane kernel's time. */
typedef struct {
    float ox[LANES], oy[LANES], oz[LANES], dx[LANES], dy[LANES], dz[LANES], ix[LANES], iy[LANES], iz[LANES];
    float sx[LANES], sy[LANES], sz[LANES];
    int kx[LANES], ky[LANES], kz[LANES];
} LaneRays;

INLINE void make_lane_rays(V3 o, V3 d, LaneRays *r) {
    LF ax = abs_l(d.x), ay = abs_l(d.y), az = abs_l(d.z);
    LI kz = ax > ay ? (ax > az ? (LI)(0) : (LI)(2)) : (ay > az ? (LI)(1) : (LI)(2));
    LI kx = kz == 2 ? (LI)(0) : kz + 1;
    LI ky = kx == 2 ? (LI)(0) : kx + 1;
    LF along_z = kz == 0 ? d.x : (kz == 1 ? d.y : d.z), along_x = kx == 0 ? d.x : (kx == 1 ? d.y : d.z);
    LF along_y = ky == 0 ? d.x : (ky == 1 ? d.y : d.z);
#define STORE(v, a) LANES_CAT(vstore, LANES)(v, 0, r->a)
    STORE(o.x, ox); STORE(o.y, oy); STORE(o.z, oz); STORE(d.x, dx); STORE(d.y, dy); STORE(d.z, dz);
    STORE(1.0f / d.x, ix); STORE(1.0f / d.y, iy); STORE(1.0f / d.z, iz);
    STORE(-along_x / along_z, sx); STORE(-along_y / along_z, sy); STORE(1.0f / along_z, sz);
    STORE(kx, kx); STORE(ky, ky); STORE(kz, kz);
#undef STORE
}

/* lane k's ray */
INLINE Ray lane_ray(const LaneRays *r, int k) {
    Ray ray;
    ray.o = (float3)(r->ox[k], r->oy[k], r->oz[k]);
    ray.d = (float3)(r->dx[k], r->dy[k], r->dz[k]);
    ray.inv_d = (float3)(r->ix[k], r->iy[k], r->iz[k]);
    ray.kx = r->kx[k]; ray.ky = r->ky[k]; ray.kz = r->kz[k];
    ray.sx = r->sx[k]; ray.sy = r->sy[k]; ray.sz = r->sz[k];
    return ray;
}

/* seen_hit for the lanes in `todo`, each lane's answer into *h: each lane's ray (`rays`, o and d its origin and direction)
 * walked alone from t_min to t_max (traversal stays per ray, docs/lanes.md), its visits added to *visits; then in
 * lanes, through ALPHA_LAYERS of them, the lanes that met a point the ray looks past walked again past it: a culled
 * back face for `camera` lanes (CULL_BACKFACES), a point the alpha test leaves out (ALPHA_TEST, its draws from rng in
 * the lanes that draw).  The tests run in lanes (their surfaces and textures are lane-generic code), so this loop is
 * the lanes' own. */
INLINE void seen_lanes(const PathScene *s, const LaneRays *rays, V3 o, V3 d, LF t_min, LF t_max, LI todo, LI camera, Rng *rng,
                       LU *visits, HitL *h) {
    LI layer = 0;
    while (ANY(todo)) {
        for (int k = 0; k < LANES; ++k) {
            if (!LANE_I(todo, k)) continue;
            uint v = LANE_U(*visits, k);
            Hit one = closest_hit(&s->geo, lane_ray(rays, k), LANE(t_min, k), LANE(t_max, k), &v);
            LANE_U(*visits, k) = v;
            LANE(h->t, k) = one.t; LANE_I(h->slot, k) = one.slot; LANE_I(h->id, k) = one.id; LANE(h->u, k) = one.u; LANE(h->v, k) = one.v;
#if INSTANCED
            LANE_I(h->instance, k) = one.instance;
#endif
        }
        LI again = 0;
#if LOOK_PAST
        LI met = todo & (h->id >= 0) & (layer < ALPHA_LAYERS);
        if (ANY(met)) {
            HitL seen = kept_hits(*h, met);
#if CULL_BACKFACES
            LI culled = met & camera;
            if (ANY(culled)) culled &= back_culled(&s->geo, s->tex, seen, o, d);
            again = culled;
            met &= NOT(culled);
#endif
#if ALPHA_TEST
            LF opacity = 1.0f;
            if (ANY(met)) again |= met & NOT(point_kept(&s->geo, s->tex, seen, rng, met, &opacity));
#endif
        }
        layer = again ? layer + 1 : layer;
        t_min = again ? h->t : t_min; /* hits are in (t_min, t_max): a rejected one is left out next */
#endif
        todo = again;
    }
}

/* The closest hit of each live lane's ray, extend_step's answer: seen_lanes, and with HIDE_EMITTERS a camera ray that met
 * an emitting triangle walked again past it (up to HIDDEN_LAYERS); a ray counted for each seen_lanes. */
INLINE HitL extend_lanes(const PathScene *s, PathLanes *st, Rng *rng, LI live) {
    HitL h = no_hits();
    LaneRays rays;
    make_lane_rays(st->o, st->d, &rays);
    LF t_min = 0.0f;
    LI camera = st->depth == 0, todo = live;
#if HIDE_EMITTERS
    LI hidden = 0;
#endif
    while (ANY(todo)) {
        seen_lanes(s, &rays, st->o, st->d, t_min, (LF)(INF_T), todo, camera, rng, &st->visits, &h);
        PUT(st, rays, st->rays + 1U, todo);
#if HIDE_EMITTERS
        LI hide = todo & camera;
        hide &= emitter_of(s, h, hide) >= 0;
        hidden = hide ? hidden + 1 : hidden;
        todo = hide & (hidden < HIDDEN_LAYERS);
        t_min = todo ? h.t : t_min; /* the camera ray again, past this emitting triangle */
#else
        todo = 0;
#endif
    }
    return h;
}

/* Whether each shadowed lane's shadow ray reaches its end: ray_unblocked's answer (with ALPHA_TEST seen_lanes: no point
 * kept before t_max; else each lane's transmittance walk). */
INLINE LI shadows_unblocked(const PathScene *s, PathLanes *st, Rng *rng, LI shadowed) {
    LaneRays rays;
    make_lane_rays(st->shadow_o, st->shadow_d, &rays);
#if ALPHA_TEST
    HitL h = no_hits();
    seen_lanes(s, &rays, st->shadow_o, st->shadow_d, (LF)(0.0f), st->shadow_t_max, shadowed, (LI)(0), rng, &st->visits, &h);
    return shadowed & (h.id < 0);
#else
    LI unblocked = 0;
    for (int k = 0; k < LANES; ++k) {
        if (!LANE_I(shadowed, k)) continue;
        uint visits = LANE_U(st->visits, k);
        bool reached = ray_unblocked(s, lane_ray(&rays, k), LANE(st->shadow_t_max, k), 0, &visits);
        LANE_U(st->visits, k) = visits;
        LANE_I(unblocked, k) = reached ? -1 : 0;
    }
    return unblocked;
#endif
}

/* render_path's pixels LANES a work-item, one in each lane of a vector register: each lane takes its pixel's samples in
 * order, and when a lane's path ends, its pixel's next sample starts in the lane at the next step, so the lanes stay
 * busy until their pixel's last sample (docs/lanes.md).  The shading, sampling and film in lanes; the walks a lane at a
 * time.  Each pixel's sums are made in render_path's order, and the images are its bits. */
__kernel __attribute__((vec_type_hint(LF))) void render_path_lanes(
    __global const TreeNode *nodes, __global const PrimSlot *prims, __global const int *prim_object, __global const VertexNormals *normals,
    __global const VertexAttributes *attributes, __global const float4 *texels, __global const char *tables, __global const char *world,
    __global const int *pixels, PathParams params, __global char *out) {
    int base = get_global_id(0) * LANES, n_work = params.frame.n_work;
    if (base >= n_work) return;
    PathScene s = path_scene(nodes, prims, prim_object, normals, attributes, texels, tables, world, params);
    LI slot = base + AS_LI(LANE_IDS_L);
    LI pixel = gather_i(pixels, min(slot, (LI)(n_work - 1)));
    PathLanes st;
    start_pixel(&st);
    V4 splats[SPLAT_SLOTS];
#if SPLAT_RADIUS
    for (int j = 0; j < SPLAT_SLOTS; ++j) splats[j] = v4(0.0f, 0.0f, 0.0f, 0.0f);
#endif
    Rng rng = make_rng((LU)(params.frame.seed), AS_LU(pixel), (LU)(0U));
    LU sample = 0U;
    LI live = slot < n_work, start = live;
    while (ANY(live)) {
        if (ANY(start)) start_sample(&params, &st, pixel, sample, &rng, start);
        PathVertex v;
        LI on = shade_surface(&s, &st, extend_lanes(&s, &st, &rng, live), &rng, &v, live);
        LI shadowed = live & (st.shadowed != 0);
        if (ANY(shadowed)) shadow_step(&st, shadows_unblocked(&s, &st, &rng, shadowed));
        if (ANY(on)) on = scatter(&s, &st, &v, &rng, on);
        LI ended = live & NOT(on);
        if (ANY(ended)) finish_sample(&st, splats, ended);
        sample = ended ? sample + 1U : sample;
        start = ended & (sample < (uint)params.spp);
        live = (live & NOT(ended)) | start;
    }
    for (int k = 0; k < LANES && base + k < n_work; ++k) {
#if SPLAT_RADIUS
        __global float4 *colour_out = REGION(out, float4, params.frame.out.colour) + (base + k) * SPLAT_SLOTS;
        for (int j = 0; j < SPLAT_SLOTS; ++j) colour_out[j] = (float4)(LANE(splats[j].x, k), LANE(splats[j].y, k), LANE(splats[j].z, k), LANE(splats[j].w, k));
#endif
        write_pixel(&params, base + k, out, lane3(st.sum, k), LANE(st.weight_sum, k), lane3(st.normal_sum, k), lane3(st.albedo_sum, k),
                    LANE_I(st.first_object, k), LANE(st.first_depth, k), LANE_U(st.visits, k), LANE_U(st.rays, k));
    }
}
#endif

#ifndef LANES
#error "a header undefined LANES (kernels/lanes.h): the lane-generic code after it took its lane branches"
#endif
