/* What hand-written lanes give the path tracer's shading on a CPU (bench/lanes.py, docs/lanes.md).  A pixel's spp
 * paths, each vertex render_path's arithmetic for two lobes: the surface from a hit, the owen-scrambled Sobol pairs,
 * NEE to an emissive triangle with MIS, the lobe's sample (Lambert: cosine-weighted; GGX conductor: visible normals),
 * Russian roulette.  Written once over kernels/lanes.h's lane type and compiled for one pixel a work-item (LANES 1)
 * and for LANES pixels a work-item, one in each lane of a vector register (8 or 16):
 *   - the lobes are bsdf.h's, through the path tracer's dispatch (component_eval, component_pdf, component_sample):
 *     masked passes, a lobe's code run when some lane's surface has it and its results kept where the lane's surface
 *     has it (at width 1: the branch of the one lobe present);
 *   - REFILL 1: a lane whose path ends starts its pixel's next sample in the next step, so lanes stay busy until
 *     their pixel's last sample; REFILL 0: the lanes' k-th samples start together, when all k-1-th paths have ended.
 * Each pixel adds its samples' radiance in sample order, so every width and either REFILL gives the same bits.
 * Traversal is not in it: the hits are given (a primitive and barycentrics per pixel and depth), so the probe times
 * shading alone, and every light sample is taken as visible. */

/* the sampler (rng.h, sobol.h) and the lobes (bsdf.h): the path tracer's own, over lanes.h's lane type */
#define DET_MATH 1
#include "sobol.h"
#include "lanes.h"
#include "bsdf.h"

#ifndef REFILL
#define REFILL 1
#endif

/* ---- the sampler: sobol.h's owen-scrambled Sobol pairs, in lanes */
/* Pair `pair` of the sample whose index is `index_reversed` in the pixel keyed `key` */
INLINE void sobol2(LU key, LU index_reversed, LU pair, LF *u0, LF *u1) {
    SobolPair q = sobol_pair(key, index_reversed, pair);
    *u0 = u01(sobol_pair_coordinate(q, 0U));
    *u1 = u01(sobol_pair_coordinate(q, 1U));
}

/* ---- the lobes: bsdf.h's Lambert and GGX conductor (Mitsuba's separable masking term), through its dispatch */
INLINE Component matte_or_metal(LI metal, V3 a, LF alpha) {
    Component c;
    c.lobe = metal ? (LI)(BSDF_CONDUCTOR) : (LI)(BSDF_LAMBERT);
    BsdfParams p;
    p.colour = a;
    p.alpha = alpha;
    p.eta = p.metallic = p.coat_weight = p.coat_internal = p.specular_prob = 0.0f;
    p.smith = SMITH_SEPARABLE;
    p.eta3 = p.k3 = p.tint = p.transmit_tint = v3_all(1.0f);
    p.nonlinear = p.coat_table = 0;
    p.coat_tables = 0;
    c.bsdf = p;
    return c;
}

/* NEE's point on one of the two emitters (u0 picks one, by area; u0 rescaled and u1 place the point): the direction wi
 * from p and its density; the emitter in *e. */
INLINE V3 light_point(__global const float *tris, int2 emitters, float emitter_area, V3 p, LF u0, LF u1, LI *e, LF *pdf) {
    *e = u0 < 0.5f ? (LI)(emitters.x) : (LI)(emitters.y);
    LF ux = u0 < 0.5f ? u0 * 2.0f : u0 * 2.0f - 1.0f;
    V3 w0 = gather3(tris, 9 * *e), w1 = gather3(tris, 9 * *e + 3), w2 = gather3(tris, 9 * *e + 6);
    LF su = sqrt_l(ux);
    V3 y = vadd(vadd(vscale(1.0f - su, w0), vscale(su * (1.0f - u1), w1)), vscale(su * u1, w2));
    V3 to_l = vsub(y, p);
    LF dist = sqrt_l(vdot(to_l, to_l));
    V3 wi = vdiv(to_l, dist);
    LF cos_l = -vdot(vunit(vcross(vsub(w1, w0), vsub(w2, w0))), wi);
    *pdf = 0.5f * dist * dist / (emitter_area * cos_l);
    return wi;
}

/* The lanes in `start` begin sample `sample` of their pixel (keyed `key`): its camera ray from the sample's first
 * pair, uniform on the sphere. */
INLINE void start_paths(LI start, LU key, LI sample, LU *index_reversed, V3 *d, V3 *beta, V3 *radiance) {
    LU index = reverse_bits32(AS_LU(sample));
    LF c0, c1, s, c;
    sobol2(key, index, (LU)(0U), &c0, &c1);
    sincos_l(2.0f * M_PI_F * c1, &s, &c);
    LF z = 1.0f - 2.0f * c0, r = sqrt_l(max_l(0.0f, 1.0f - z * z));
    *d = vpick(start, v3(r * c, r * s, z), *d);
    *beta = vpick(start, v3_all(1.0f), *beta);
    *radiance = vpick(start, v3_all(0.0f), *radiance);
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
    LU key = sobol_pixel_key((LU)(seed), pixel);
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
        V3 c0 = gather3(tris, 9 * prim), c1 = gather3(tris, 9 * prim + 3), c2 = gather3(tris, 9 * prim + 6);
        V3 e1 = vsub(c1, c0), e2 = vsub(c2, c0);
        V3 p = vadd(c0, vadd(vscale(hu, e1), vscale(hv, e2)));
        V3 ng = vunit(vcross(e1, e2));
        ng = vpick(vdot(ng, d) > 0.0f, vneg(ng), ng);
        V3 a = gather3(mats, 8 * prim), le = gather3(mats, 8 * prim + 3);
        LI metal = live & (gather(mats, 8 * prim + 6) != 0.0f);
        LF alpha = gather(mats, 8 * prim + 7);
        radiance = vpick(live, vadd(radiance, vmul(beta, le)), radiance);
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
        V3 wo = to_local(fr, vneg(d)), wl = to_local(fr, wi);
        Component c = matte_or_metal(metal, a, alpha);
        V3 f = component_eval(c, wo, wl);
        LF lobe_pdf = component_pdf(c, wo, wl);
        BsdfSample bs = component_sample(c, wo, ub0, v2(ub0, ub1));
        V3 wn = bs.wi, weight = bs.weight;
        LI lit = live & (light_pdf > 0.0f) & (light_pdf < INFINITY) & (wo.z > 0.0f);
        LF w = light_pdf / (light_pdf * light_pdf + lobe_pdf * lobe_pdf);
        radiance = vpick(lit, vadd(radiance, vmul(beta, vscale(w, vmul(f, gather3(mats, 8 * e + 3))))), radiance);
        beta = vpick(live, vmul(beta, weight), beta);
        d = vpick(live, to_world(fr, wn), d);
        /* Russian roulette from the third vertex; the path ends there, at its last vertex, or below the surface */
        LF q = min_l(max3_l(beta), 0.95f);
        LI late = vertex >= 2;
        LI ended = live & ((late & (urr >= q)) | (vertex == depth - 1) | (wo.z <= 0.0f) | (max3_l(beta) <= 0.0f));
        LF keep = late ? q : (LF)(1.0f);
        beta = vdiv(beta, keep);
        total = vpick(ended, vadd(total, radiance), total);
        vertex = (live & NOT(ended)) ? vertex + 1 : 0;
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
