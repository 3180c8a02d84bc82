/* What hand-written lanes give the path tracer's shading on a CPU (bench/lanes.py, docs/lanes.md): one diffuse bounce
 * of render_path's arithmetic (the surface from a hit, the owen-scrambled Sobol pairs, NEE to an emissive triangle
 * with MIS, the cosine-weighted BSDF sample, Russian roulette), written once over a lane type and compiled for one
 * path per work-item (LANES 1) and for LANES paths per work-item in vector registers (8 or 16).  Traversal is not in
 * it: the hits are given (a primitive and its barycentrics per path and bounce), so the probe times shading alone,
 * and the visibility of every light sample is taken as 1.  Both widths compute the same operations in the same
 * order, so they give the same bits. */

/* the sampler's steps (rng.h's MIX32_STEPS, sampling.h's LAINE_KARRAS_STEPS, sobol.h's SUPERSET_XOR_STEPS and keys) and
 * mathf.h's polynomials, the scalar path tracer's own */
#define DET_MATH 1
#include "sobol.h"
#pragma OPENCL FP_CONTRACT ON /* as in path.cl's surface and BSDF code (mathf.h turns it off) */

#ifndef LANES
#define LANES 16
#endif

#if LANES == 1
typedef float LF;
typedef int LI;
typedef uint LU;
#define AS_LF(x) as_float(x)
#define AS_LU(x) as_uint(x)
#define NOT(m) (!(m))
#define ANY(m) (m)
#define LOAD_F(p) (*(p))
#define LOAD_I(p) (*(p))
#define STORE_F(v, p) (*(p) = (v))
#define CONVERT_I(x) convert_int(x)
INLINE LF gather(__global const float *b, LI i) { return b[i]; }
#else
#define CAT_(a, b) a##b
#define CAT(a, b) CAT_(a, b)
typedef CAT(float, LANES) LF;
typedef CAT(int, LANES) LI;
typedef CAT(uint, LANES) LU;
#define AS_LF(x) CAT(as_float, LANES)(x)
#define AS_LU(x) CAT(as_uint, LANES)(x)
#define NOT(m) (~(m))
#define ANY(m) any(m)
#define LOAD_F(p) CAT(vload, LANES)(0, p)
#define LOAD_I(p) CAT(vload, LANES)(0, p)
#define STORE_F(v, p) CAT(vstore, LANES)(v, 0, p)
#define CONVERT_I(x) CAT(convert_int, LANES)(x)
__constant uint LANE_IDS[16] = {0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15};
/* LANES scalar loads: OpenCL C has no gather; the compiler inserts them lane by lane */
INLINE LF gather(__global const float *b, LI i) {
#if LANES == 16
    return (LF)(b[i.s0], b[i.s1], b[i.s2], b[i.s3], b[i.s4], b[i.s5], b[i.s6], b[i.s7], b[i.s8], b[i.s9], b[i.sa],
                b[i.sb], b[i.sc], b[i.sd], b[i.se], b[i.sf]);
#else
    return (LF)(b[i.s0], b[i.s1], b[i.s2], b[i.s3], b[i.s4], b[i.s5], b[i.s6], b[i.s7]);
#endif
}
#endif

typedef struct {
    LF x, y, z;
} V3;

INLINE V3 v3(LF x, LF y, LF z) { V3 v = {x, y, z}; return v; }
INLINE V3 add(V3 a, V3 b) { return v3(a.x + b.x, a.y + b.y, a.z + b.z); }
INLINE V3 sub(V3 a, V3 b) { return v3(a.x - b.x, a.y - b.y, a.z - b.z); }
INLINE V3 mul(V3 a, V3 b) { return v3(a.x * b.x, a.y * b.y, a.z * b.z); }
INLINE V3 scale(LF s, V3 a) { return v3(s * a.x, s * a.y, s * a.z); }
INLINE V3 neg(V3 a) { return v3(-a.x, -a.y, -a.z); }
INLINE LF dot(V3 a, V3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
INLINE V3 cross(V3 a, V3 b) { return v3(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x); }
INLINE LF sqrt_l(LF x) { return sqrt(x); } /* correctly rounded: the same bits in every lane width */
INLINE V3 unit(V3 a) { LF s = sqrt_l(dot(a, a)); return v3(a.x / s, a.y / s, a.z / s); }
INLINE V3 pick(LI m, V3 a, V3 b) { return v3(m ? a.x : b.x, m ? a.y : b.y, m ? a.z : b.z); }
INLINE LF max_l(LF a, LF b) { return a > b ? a : b; }
INLINE LF min_l(LF a, LF b) { return a < b ? a : b; }
INLINE V3 gather3(__global const float *b, LI i) { return v3(gather(b, 3 * i), gather(b, 3 * i + 1), gather(b, 3 * i + 2)); }

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
INLINE LF u01_l(LU h) {
    LU q = h >> 8;
    LF halves = AS_LF((q >> 1) | 0x4b000000U) - 8388608.0f;
    LF odd = (q & 1U) != 0U ? (LF)(1.0f) : (LF)(0.0f);
    return (halves * 2.0f + odd) * U01_SCALE;
}
/* Pair `pair` of the sample whose index is `index_reversed` in the pixel keyed `key` (sobol_pair, sobol_pair_coordinate) */
INLINE void sobol2(LU key, LU index_reversed, uint pair, LF *u0, LF *u1) {
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

/* n_paths paths (a multiple of LANES), `bounces` vertices each.  tris: 9 floats a triangle (v0, v1, v2); albedo and
 * emission: 3 a triangle; emitters: the two emissive triangles' ids, each of area emitter_area; hit_prim
 * [bounce][path] and hit_uv [2][bounce][path]: the given hits; d0: the camera rays' directions, [3][path].  Out: each
 * path's radiance, [3][path]. */
__kernel void shade_probe(int n_paths, int bounces, __global const float *tris, __global const float *albedo,
                          __global const float *emission, int2 emitters, float emitter_area, uint seed,
                          __global const int *hit_prim, __global const float *hit_uv, __global const float *d0,
                          __global float *out) {
    int base = get_global_id(0) * LANES;
    if (base >= n_paths) return;
#if LANES == 1
    LU pixel = (uint)base;
#else
    LU pixel = (uint)base + CAT(vload, LANES)(0, LANE_IDS);
#endif
    LU key = mix_l(mix_l(mix_l((LU)(seed + 0x9e3779b9U)) ^ (pixel + 0x85ebca6bU)) ^ (SOBOL_KEY_PAIR + 0xc2b2ae35U)); /* hash3 */
    LU index_reversed = (LU)(0U); /* sample 0 */
    V3 d = v3(LOAD_F(d0 + base), LOAD_F(d0 + n_paths + base), LOAD_F(d0 + 2 * n_paths + base));
    V3 beta = v3((LF)(1.0f), (LF)(1.0f), (LF)(1.0f)), radiance = v3((LF)(0.0f), (LF)(0.0f), (LF)(0.0f));
    LI alive = (LF)(1.0f) > 0.0f;
    for (int b = 0; b < bounces && ANY(alive); ++b) {
        int at = b * n_paths + base;
        LI prim = LOAD_I(hit_prim + at);
        LF hu = LOAD_F(hit_uv + at), hv = LOAD_F(hit_uv + bounces * n_paths + at);
        /* the surface */
        V3 v0 = gather3(tris, 3 * prim), v1 = gather3(tris, 3 * prim + 1), v2 = gather3(tris, 3 * prim + 2);
        V3 e1 = sub(v1, v0), e2 = sub(v2, v0);
        V3 p = add(v0, add(scale(hu, e1), scale(hv, e2)));
        V3 ng = unit(cross(e1, e2));
        ng = pick(dot(ng, d) > 0.0f, neg(ng), ng);
        V3 a = gather3(albedo, prim), le = gather3(emission, prim);
        radiance = pick(alive, add(radiance, mul(beta, le)), radiance);
        /* four dimensions of the vertex: the light's point, the BSDF's direction; then roulette */
        LF ul0, ul1, ub0, ub1, urr, unused;
        sobol2(key, index_reversed, 4 * b + 1, &ul0, &ul1);
        sobol2(key, index_reversed, 4 * b + 2, &ub0, &ub1);
        sobol2(key, index_reversed, 4 * b + 3, &urr, &unused);
        /* NEE to one of the two emitters, by area, MIS against the cosine lobe */
        LI e = ul0 < 0.5f ? (LI)(emitters.x) : (LI)(emitters.y);
        LF ux = ul0 < 0.5f ? ul0 * 2.0f : ul0 * 2.0f - 1.0f;
        V3 w0 = gather3(tris, 3 * e), w1 = gather3(tris, 3 * e + 1), w2 = gather3(tris, 3 * e + 2);
        LF su = sqrt_l(ux);
        V3 y = add(add(scale(1.0f - su, w0), scale(su * (1.0f - ul1), w1)), scale(su * ul1, w2));
        V3 to_l = sub(y, p);
        LF dist = sqrt_l(dot(to_l, to_l));
        V3 wi = v3(to_l.x / dist, to_l.y / dist, to_l.z / dist);
        LF cos_l = -dot(unit(cross(sub(w1, w0), sub(w2, w0))), wi);
        LF light_pdf = 0.5f * dist * dist / (emitter_area * cos_l);
        Frame fr = make_frame(ng);
        V3 wo = to_local(fr, neg(d)), wl = to_local(fr, wi);
        LF bsdf_pdf = wl.z * M_1_PI_F;
        LI lit = alive & (light_pdf > 0.0f) & (light_pdf < INFINITY) & (wl.z > 0.0f) & (wo.z > 0.0f);
        LF w = light_pdf / (light_pdf * light_pdf + bsdf_pdf * bsdf_pdf) * (wl.z * M_1_PI_F);
        V3 le_em = gather3(emission, e);
        radiance = pick(lit, add(radiance, mul(beta, scale(w, mul(a, le_em)))), radiance);
        /* the BSDF's sample */
        LF r = sqrt_l(ub0), s, c;
        sincos_l(2.0f * M_PI_F * ub1, &s, &c);
        V3 wl_next = v3(r * c, r * s, sqrt_l(max_l(0.0f, 1.0f - ub0)));
        beta = pick(alive, mul(beta, a), beta);
        d = to_world(fr, wl_next);
        /* Russian roulette from the third vertex */
        LF q = min_l(max_l(beta.x, max_l(beta.y, beta.z)), 0.95f);
        LI rr = b >= 2 ? (LI)(urr >= q) : (LI)(0);
        alive = alive & NOT(rr) & (wo.z > 0.0f);
        LF keep = b >= 2 ? q : (LF)(1.0f);
        beta = v3(beta.x / keep, beta.y / keep, beta.z / keep);
    }
    STORE_F(radiance.x, out + base);
    STORE_F(radiance.y, out + n_paths + base);
    STORE_F(radiance.z, out + 2 * n_paths + base);
}
