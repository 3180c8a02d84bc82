/* What hand-written lanes give the path tracer's shading on a CPU (bench/lanes.py, docs/lanes.md).  A pixel's spp
 * paths, each vertex render_path's arithmetic for two lobes: the surface from a hit, the owen-scrambled Sobol pairs,
 * NEE to an emissive triangle with MIS, the lobe's sample (Lambert: cosine-weighted; GGX conductor: visible normals),
 * Russian roulette.  Written once over kernels/lanes.h's lane type and compiled for one pixel a work-item (LANES 1)
 * and for LANES pixels a work-item, one in each lane of a vector register (8 or 16):
 *   - the lobes are masked passes: a lobe's code runs when some lane's surface has it, for every lane, and its
 *     results are kept where the lane's surface has it (at width 1: the branch of the one lobe present);
 *   - REFILL 1: a lane whose path ends starts its pixel's next sample in the next step, so lanes stay busy until
 *     their pixel's last sample; REFILL 0: the lanes' k-th samples start together, when all k-1-th paths have ended.
 * Each pixel adds its samples' radiance in sample order, so every width and either REFILL gives the same bits.
 * Traversal is not in it: the hits are given (a primitive and barycentrics per pixel and depth), so the probe times
 * shading alone, and every light sample is taken as visible. */

/* the sampler's steps (rng.h's MIX32_STEPS, sampling.h's LAINE_KARRAS_STEPS, sobol.h's SUPERSET_XOR_STEPS and keys) and
 * mathf.h's polynomials: the scalar path tracer's own */
#define DET_MATH 1
#include "sobol.h"
#pragma OPENCL FP_CONTRACT ON /* as in path.cl's surface and BSDF code (mathf.h turns it off) */
#include "lanes.h"

#ifndef REFILL
#define REFILL 1
#endif

/* ---- the sampler: sobol.h's owen-scrambled Sobol pairs over lanes, from its steps (bit reversal by shifts and masks,
 * where the scalar sampler looks bytes up in a table) */
INLINE LU mix_l(LU x) {
    MIX32_STEPS(x);
    return x;
}
INLINE LU reverse_l(LU x) {
    x = ((x >> 1) & 0x55555555U) | ((x & 0x55555555U) << 1);
    x = ((x >> 2) & 0x33333333U) | ((x & 0x33333333U) << 2);
    x = ((x >> 4) & 0x0f0f0f0fU) | ((x & 0x0f0f0f0fU) << 4);
    x = ((x >> 8) & 0x00ff00ffU) | ((x & 0x00ff00ffU) << 8);
    return (x >> 16) | (x << 16);
}
INLINE LU laine_karras_l(LU x, LU seed) {
    LAINE_KARRAS_STEPS(x, seed);
    return x;
}
INLINE LU superset_xor_l(LU x) {
    SUPERSET_XOR_STEPS(x);
    return x;
}
/* rng.h's u01: (float)(h >> 8) * 2^-24, the conversion by bit tricks (u01_lanes) */
INLINE LF u01_l(LU h) { U01_BITS(LF, AS_LF, h); }
/* Pair `pair` of the sample whose index is `index_reversed` in the pixel keyed `key` (sobol_pair, sobol_pair_coordinate) */
INLINE void sobol2(LU key, LU index_reversed, LU pair, LF *u0, LF *u1) {
    LU k = mix_l(key ^ (pair + HASH_KEY_D));
    LU i = reverse_l(laine_karras_l(index_reversed, k));
    *u0 = u01_l(reverse_l(laine_karras_l(i, mix_l(k ^ SOBOL_KEY_X))));
    *u1 = u01_l(reverse_l(laine_karras_l(superset_xor_l(i), mix_l(k ^ SOBOL_KEY_Y))));
}

/* ---- sin and cos of x in [0, 2 pi): mathf.h's Cody and Waite reduction and Cephes' polynomials, without branches */
INLINE void sincos_l(LF x, LF *s, LF *c) {
    LF n = floor(x * 0.636619772f + 0.5f);
    LF r = MF_CODY_WAITE(x, n), z = r * r;
    LI q = CONVERT_I(n);
    LF ps = MF_SIN_POLY(r, z), pc = MF_COS_POLY(z);
    LI odd = (q & 1) != 0, flip_s = (q & 2) != 0, flip_c = ((q + 1) & 2) != 0;
    LF sv = odd ? pc : ps, cv = odd ? ps : pc;
    *s = flip_s ? -sv : sv;
    *c = flip_c ? -cv : cv;
}

/* ---- the shading frame (Duff et al.) */
typedef struct {
    V3 t, b, n;
} Frame;
INLINE Frame make_frame(V3 n) {
    LF sign = n.z >= 0.0f ? (LF)(1.0f) : (LF)(-1.0f);
    LF a = -1.0f / (sign + n.z);
    LF c = n.x * n.y * a;
    Frame f;
    f.t = v3(1.0f + sign * n.x * n.x * a, sign * c, -sign * n.x);
    f.b = v3(c, sign + n.y * n.y * a, -n.y);
    f.n = n;
    return f;
}
INLINE V3 to_local(Frame f, V3 v) { return v3(dot(v, f.t), dot(v, f.b), dot(v, f.n)); }
INLINE V3 to_world(Frame f, V3 v) { return add(add(scale(v.x, f.t), scale(v.y, f.b)), scale(v.z, f.n)); }

/* ---- the lobes (bsdf.h's): eval is f cos, wi and wo local and away from the surface */
INLINE V3 cosine_sample(LF u0, LF u1) {
    LF r = sqrt_l(u0), s, c;
    sincos_l(2.0f * M_PI_F * u1, &s, &c);
    return v3(r * c, r * s, sqrt_l(max_l(0.0f, 1.0f - u0)));
}
/* GGX (Trowbridge-Reitz) of width alpha: D, Smith's G1, and the visible normals' sample (Heitz 2018) */
INLINE LF ggx_d(LF hz, LF alpha) {
    LF a2 = alpha * alpha, t = hz * hz * (a2 - 1.0f) + 1.0f;
    return a2 / (M_PI_F * t * t);
}
INLINE LF ggx_g1(V3 w, LF alpha) { return 2.0f * w.z / (w.z + sqrt_l(alpha * alpha * (w.x * w.x + w.y * w.y) + w.z * w.z)); }
INLINE V3 ggx_visible_normal(V3 wo, LF alpha, LF u0, LF u1) {
    V3 vh = unit(v3(alpha * wo.x, alpha * wo.y, wo.z));
    LF len2 = vh.x * vh.x + vh.y * vh.y;
    LF inv = len2 > 0.0f ? 1.0f / sqrt_l(len2) : (LF)(0.0f);
    V3 t1 = v3(len2 > 0.0f ? -vh.y * inv : (LF)(1.0f), len2 > 0.0f ? vh.x * inv : (LF)(0.0f), (LF)(0.0f));
    V3 t2 = cross(vh, t1);
    LF r = sqrt_l(u0), s, c;
    sincos_l(2.0f * M_PI_F * u1, &s, &c);
    LF p1 = r * c, p2 = r * s, h = 0.5f * (1.0f + vh.z);
    p2 = (1.0f - h) * sqrt_l(max_l(0.0f, 1.0f - p1 * p1)) + h * p2;
    V3 nh = add(add(scale(p1, t1), scale(p2, t2)), scale(sqrt_l(max_l(0.0f, 1.0f - p1 * p1 - p2 * p2)), vh));
    return unit(v3(alpha * nh.x, alpha * nh.y, max_l(0.0f, nh.z)));
}
/* a conductor's f cos (Schlick's Fresnel from its colour f0) and its sampling density, for wi */
INLINE V3 ggx_eval(V3 wo, V3 wi, V3 f0, LF alpha, LF *pdf) {
    V3 h = unit(add(wo, wi));
    LF d = ggx_d(h.z, alpha), g1o = ggx_g1(wo, alpha);
    LF m = 1.0f - max_l(0.0f, dot(wo, h)), m5 = (m * m) * (m * m) * m;
    V3 f = add(f0, scale(m5, sub(v3_all(1.0f), f0)));
    *pdf = g1o * d / (4.0f * wo.z);
    return scale(d * g1o * ggx_g1(wi, alpha) / (4.0f * wo.z), f);
}

/* Each lobe present, a masked pass: its f cos and density towards the light wl, its sample (u0, u1) and the sample's
 * weight, kept in the lanes whose surface has it (matte: Lambert of albedo a; metal: a GGX conductor of colour a). */
INLINE void lobes(LI matte, LI metal, V3 a, LF alpha, V3 wo, V3 wl, LF u0, LF u1, V3 *f, LF *pdf, V3 *wn, V3 *weight) {
    *f = *wn = *weight = v3_all(0.0f);
    *pdf = 0.0f;
    if (ANY(matte)) {
        LF cos_i = max_l(wl.z, 0.0f);
        *f = pick(matte, scale(cos_i * M_1_PI_F, a), *f);
        *pdf = matte ? cos_i * M_1_PI_F : *pdf;
        *wn = pick(matte, cosine_sample(u0, u1), *wn);
        *weight = pick(matte, a, *weight);
    }
    if (ANY(metal)) {
        LF metal_pdf;
        V3 fm = ggx_eval(wo, wl, a, alpha, &metal_pdf);
        LI above = wl.z > 0.0f;
        *f = pick(metal & above, fm, *f);
        *pdf = metal & above ? metal_pdf : *pdf;
        V3 h = ggx_visible_normal(wo, alpha, u0, u1);
        V3 ws = sub(scale(2.0f * dot(wo, h), h), wo);
        LF m = 1.0f - max_l(0.0f, dot(wo, h)), m5 = (m * m) * (m * m) * m;
        V3 fresnel = add(a, scale(m5, sub(v3_all(1.0f), a)));
        *wn = pick(metal, ws, *wn);
        *weight = pick(metal, pick(ws.z > 0.0f, scale(ggx_g1(ws, alpha), fresnel), v3_all(0.0f)), *weight);
    }
}

/* NEE's point on one of the two emitters (u0 picks one, by area; u0 rescaled and u1 place the point): the direction wi
 * from p and its density; the emitter in *e. */
INLINE V3 light_point(__global const float *tris, int2 emitters, float emitter_area, V3 p, LF u0, LF u1, LI *e, LF *pdf) {
    *e = u0 < 0.5f ? (LI)(emitters.x) : (LI)(emitters.y);
    LF ux = u0 < 0.5f ? u0 * 2.0f : u0 * 2.0f - 1.0f;
    V3 w0 = gather3(tris, 9 * *e), w1 = gather3(tris, 9 * *e + 3), w2 = gather3(tris, 9 * *e + 6);
    LF su = sqrt_l(ux);
    V3 y = add(add(scale(1.0f - su, w0), scale(su * (1.0f - u1), w1)), scale(su * u1, w2));
    V3 to_l = sub(y, p);
    LF dist = sqrt_l(dot(to_l, to_l));
    V3 wi = divide(to_l, dist);
    LF cos_l = -dot(unit(cross(sub(w1, w0), sub(w2, w0))), wi);
    *pdf = 0.5f * dist * dist / (emitter_area * cos_l);
    return wi;
}

/* The lanes in `start` begin sample `sample` of their pixel (keyed `key`): its camera ray from the sample's first
 * pair, uniform on the sphere. */
INLINE void start_paths(LI start, LU key, LI sample, LU *index_reversed, V3 *d, V3 *beta, V3 *radiance) {
    LU index = reverse_l(AS_LU(sample));
    LF c0, c1, s, c;
    sobol2(key, index, (LU)(0U), &c0, &c1);
    sincos_l(2.0f * M_PI_F * c1, &s, &c);
    LF z = 1.0f - 2.0f * c0, r = sqrt_l(max_l(0.0f, 1.0f - z * z));
    *d = pick(start, v3(r * c, r * s, z), *d);
    *beta = pick(start, v3_all(1.0f), *beta);
    *radiance = pick(start, v3_all(0.0f), *radiance);
    *index_reversed = start ? index : *index_reversed;
}

/* n_pixels pixels (a multiple of LANES), spp samples each of at most `depth` vertices.  tris: 9 floats a triangle (v0,
 * v1, v2); mats: 8 a triangle (albedo or f0, emission, lobe: 0 Lambert, 1 GGX conductor, alpha); emitters: the two
 * emissive triangles' ids, each of area emitter_area; hit_prim [depth][pixel] and hit_uv [2][depth][pixel]: the given
 * hits.  Out: each pixel's radiance summed over its samples, [3][pixel]; steps: each work-item's steps and the lanes
 * live in them, summed (the lanes' occupancy). */
__kernel void shade_probe(int n_pixels, int spp, int depth, __global const float *tris, __global const float *mats,
                          int2 emitters, float emitter_area, uint seed, __global const int *hit_prim,
                          __global const float *hit_uv, __global float *out, __global int *steps) {
    int base = get_global_id(0) * LANES;
    if (base >= n_pixels) return;
    LU pixel = (uint)base + LANE_IDS_L;
    LU key = mix_l(mix_l(mix_l((LU)(seed + 0x9e3779b9U)) ^ (pixel + 0x85ebca6bU)) ^ (SOBOL_KEY_PAIR + 0xc2b2ae35U)); /* hash3 */
    V3 total = v3_all(0.0f), beta = v3_all(1.0f), radiance = v3_all(0.0f), d = v3_all(0.0f);
    LI sample = 0, vertex = 0, live = (LI)(0) == 0, start = live;
    LU index_reversed = 0U;
    int steps_taken = 0, lanes_live = 0;
    while (ANY(live)) {
        if (ANY(start)) start_paths(start, key, sample, &index_reversed, &d, &beta, &radiance);
        steps_taken += 1;
        lanes_live += lanes_set(live);
        LI at = vertex * n_pixels + CONVERT_I(pixel);
        LI prim = gather_i(hit_prim, at);
        LF hu = gather(hit_uv, at), hv = gather(hit_uv, at + depth * n_pixels);
        /* the surface and its material */
        V3 v0 = gather3(tris, 9 * prim), v1 = gather3(tris, 9 * prim + 3), v2 = gather3(tris, 9 * prim + 6);
        V3 e1 = sub(v1, v0), e2 = sub(v2, v0);
        V3 p = add(v0, add(scale(hu, e1), scale(hv, e2)));
        V3 ng = unit(cross(e1, e2));
        ng = pick(dot(ng, d) > 0.0f, neg(ng), ng);
        V3 a = gather3(mats, 8 * prim), le = gather3(mats, 8 * prim + 3);
        LI metal = live & (gather(mats, 8 * prim + 6) != 0.0f), matte = live & NOT(metal);
        LF alpha = gather(mats, 8 * prim + 7);
        radiance = pick(live, add(radiance, mul(beta, le)), radiance);
        /* the vertex's dimensions: the light's point, the lobe's direction, roulette */
        LU dims = 4U * AS_LU(vertex);
        LF ul0, ul1, ub0, ub1, urr, unused;
        sobol2(key, index_reversed, dims + 1U, &ul0, &ul1);
        sobol2(key, index_reversed, dims + 2U, &ub0, &ub1);
        sobol2(key, index_reversed, dims + 3U, &urr, &unused);
        LI e;
        LF light_pdf;
        V3 wi = light_point(tris, emitters, emitter_area, p, ul0, ul1, &e, &light_pdf);
        Frame fr = make_frame(ng);
        V3 wo = to_local(fr, neg(d)), wl = to_local(fr, wi);
        V3 f, wn, weight;
        LF lobe_pdf;
        lobes(matte, metal, a, alpha, wo, wl, ub0, ub1, &f, &lobe_pdf, &wn, &weight);
        LI lit = live & (light_pdf > 0.0f) & (light_pdf < INFINITY) & (wo.z > 0.0f);
        LF w = light_pdf / (light_pdf * light_pdf + lobe_pdf * lobe_pdf);
        radiance = pick(lit, add(radiance, mul(beta, scale(w, mul(f, gather3(mats, 8 * e + 3))))), radiance);
        beta = pick(live, mul(beta, weight), beta);
        d = pick(live, to_world(fr, wn), d);
        /* Russian roulette from the third vertex; the path ends there, at its last vertex, or below the surface */
        LF q = min_l(max3_l(beta), 0.95f);
        LI late = vertex >= 2;
        LI ended = live & ((late & (urr >= q)) | (vertex == depth - 1) | (wo.z <= 0.0f) | (max3_l(beta) <= 0.0f));
        LF keep = late ? q : (LF)(1.0f);
        beta = divide(beta, keep);
        total = pick(ended, add(total, radiance), total);
        vertex = live & NOT(ended) ? vertex + 1 : 0;
        sample = ended ? sample + 1 : sample;
#if REFILL
        start = ended & (sample < spp);
        live = (live & NOT(ended)) | start;
#else
        live = live & NOT(ended);
        start = NOT(live) & (sample < spp);
        if (ANY(live)) start = 0; /* the next samples start together, once every lane's path has ended */
        live = live | start;
#endif
    }
    for (int k = 0; k < 3; ++k) {
        LF v = k == 0 ? total.x : k == 1 ? total.y : total.z;
#if LANES == 1
        out[k * n_pixels + base] = v;
#else
        LANES_CAT(vstore, LANES)(v, 0, out + k * n_pixels + base);
#endif
    }
    steps[2 * get_global_id(0)] = steps_taken;
    steps[2 * get_global_id(0) + 1] = lanes_live;
}
