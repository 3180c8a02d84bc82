/* A lane type: LANES paths a work-item, each in one lane of a vector register (LANES 8 or 16), or one path a
 * work-item (LANES 1, the default), from the same source.  Code written over these types computes the same operations
 * in the same order at every width, so it gives the same bits at every width (kernels/bsdf.h, kernels/lanes_probe.cl,
 * docs/lanes.md):
 *   LF, LI, LU     float, int, uint lanes (float, int, uint at width 1)
 *   V3, V2, V4     3-, 2- and 4-vectors of lanes, structs of LF (not float3: each component is a register of lanes);
 *                  at width 1 float3, float2 and float4, so lane-generic and scalar code pass values freely
 *   masks          LI from comparisons: -1 or 0 a lane (1 or 0 at width 1); combine with & and |, negate with NOT,
 *                  test with ANY; choose with ?: on an LF or LU (or vpick, on a V3), never with a branch on a lane.
 *                  `if (ANY(m)) x = vpick(m, ..., x)` is a masked pass: at width 1, the branch the scalar code took
 *   gather         one float per lane from lane-varying indices: LANES scalar loads (OpenCL C has no gather);
 *                  FIELD_F, FIELD_I, FIELD3: a float, int or float[3] field of a __global record array at a
 *                  lane-varying index
 * Include after mathf.h and before intersect.h, where common.h is: vdot and vcross then round as its dot3 and cross3
 * (FP_CONTRACT off in a DET_MATH program, on in the Whitted one).  Headers shared by both integrators (rng.h, sobol.h)
 * are written over these types, which at width 1 are the plain ones. */
#ifndef CLRENDER_LANES_H
#define CLRENDER_LANES_H

#include "mathf.h"

#ifndef LANES
#define LANES 1
#endif
#if LANES > 1 && !DET_MATH
#error "lanes need mathf.h's DET_MATH steps (sincos_l)"
#endif

#if LANES == 1
typedef float LF;
typedef int LI;
typedef uint LU;
#define AS_LF(x) as_float(x)
#define AS_LU(x) as_uint(x)
#define AS_LI(x) as_int(x)
#define NOT(m) (!(m))
#define ANY(m) (m)
#define ALL(m) (m)
#define CONVERT_I(x) convert_int(x)
#define CONVERT_F(x) convert_float(x)
#define LANE_IDS_L ((LU)(0U))
INLINE LF gather(__global const float *b, LI i) { return b[i]; }
INLINE LI gather_i(__global const int *b, LI i) { return b[i]; }
INLINE LU gather_u(__global const uint *b, LU i) { return b[i]; }
#define FIELD_F(p, i, f) ((p)[i].f)
#define FIELD_I(p, i, f) ((p)[i].f)
#define FIELD3(p, i, f) vload3(0, (p)[i].f)
#else
#define LANES_CAT_(a, b) a##b
#define LANES_CAT(a, b) LANES_CAT_(a, b)
typedef LANES_CAT(float, LANES) LF;
typedef LANES_CAT(int, LANES) LI;
typedef LANES_CAT(uint, LANES) LU;
#define AS_LF(x) LANES_CAT(as_float, LANES)(x)
#define AS_LU(x) LANES_CAT(as_uint, LANES)(x)
#define AS_LI(x) LANES_CAT(as_int, LANES)(x)
#define NOT(m) (~(m))
#define ANY(m) any(m)
#define ALL(m) all(m)
#define CONVERT_I(x) LANES_CAT(convert_int, LANES)(x)
#define CONVERT_F(x) LANES_CAT(convert_float, LANES)(x)
__constant uint LANE_INDICES[16] = {0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15};
#define LANE_IDS_L LANES_CAT(vload, LANES)(0, LANE_INDICES)
#if LANES == 16
#define GATHER_LANES(b, i)                                                                                             \
    (b[i.s0], b[i.s1], b[i.s2], b[i.s3], b[i.s4], b[i.s5], b[i.s6], b[i.s7], b[i.s8], b[i.s9], b[i.sa], b[i.sb], b[i.sc], \
     b[i.sd], b[i.se], b[i.sf])
#else
#define GATHER_LANES(b, i) (b[i.s0], b[i.s1], b[i.s2], b[i.s3], b[i.s4], b[i.s5], b[i.s6], b[i.s7])
#endif
INLINE LF gather(__global const float *b, LI i) { return (LF)GATHER_LANES(b, i); }
#if LANES == 16
#define FIELD_LANES(p, i, f)                                                                                             \
    ((p)[(i).s0].f, (p)[(i).s1].f, (p)[(i).s2].f, (p)[(i).s3].f, (p)[(i).s4].f, (p)[(i).s5].f, (p)[(i).s6].f, (p)[(i).s7].f, \
     (p)[(i).s8].f, (p)[(i).s9].f, (p)[(i).sa].f, (p)[(i).sb].f, (p)[(i).sc].f, (p)[(i).sd].f, (p)[(i).se].f, (p)[(i).sf].f)
#else
#define FIELD_LANES(p, i, f) \
    ((p)[(i).s0].f, (p)[(i).s1].f, (p)[(i).s2].f, (p)[(i).s3].f, (p)[(i).s4].f, (p)[(i).s5].f, (p)[(i).s6].f, (p)[(i).s7].f)
#endif
#define FIELD_F(p, i, f) ((LF)FIELD_LANES(p, i, f))
#define FIELD_I(p, i, f) ((LI)FIELD_LANES(p, i, f))
#define FIELD3(p, i, f) v3(FIELD_F(p, i, f[0]), FIELD_F(p, i, f[1]), FIELD_F(p, i, f[2]))
INLINE LI gather_i(__global const int *b, LI i) { return (LI)GATHER_LANES(b, i); }
INLINE LU gather_u(__global const uint *b, LU i) { return (LU)GATHER_LANES(b, i); }
#endif

#if LANES == 1 /* the vector types the scalar code has always used: one path's values pass between the two freely */
typedef float3 V3;
typedef float2 V2; /* a 2-D sample or texture coordinate */
typedef float4 V4; /* a texel */
#else
typedef struct {
    LF x, y, z;
} V3;
typedef struct {
    LF x, y;
} V2;
typedef struct {
    LF x, y, z, w;
} V4;
#endif

#define ALL_LANES ((LI)(0) == (LI)(0)) /* the mask of every lane */

#if LANES == 1
INLINE V3 v3(LF x, LF y, LF z) { return (float3)(x, y, z); }
INLINE V2 v2(LF x, LF y) { return (float2)(x, y); }
INLINE V4 v4(LF x, LF y, LF z, LF w) { return (float4)(x, y, z, w); }
#else
INLINE V3 v3(LF x, LF y, LF z) { V3 v = {x, y, z}; return v; }
INLINE V2 v2(LF x, LF y) { V2 v = {x, y}; return v; }
INLINE V4 v4(LF x, LF y, LF z, LF w) { V4 v = {x, y, z, w}; return v; }
#endif
INLINE V3 v3_all(float s) { return v3((LF)(s), (LF)(s), (LF)(s)); }
#if LANES == 1
INLINE V3 xyz_of(V4 a) { return a.xyz; }
#else
INLINE V3 xyz_of(V4 a) { return v3(a.x, a.y, a.z); }
#endif
INLINE V3 vadd(V3 a, V3 b) { return v3(a.x + b.x, a.y + b.y, a.z + b.z); }
INLINE V3 vsub(V3 a, V3 b) { return v3(a.x - b.x, a.y - b.y, a.z - b.z); }
INLINE V3 vmul(V3 a, V3 b) { return v3(a.x * b.x, a.y * b.y, a.z * b.z); }
INLINE V3 vscale(LF s, V3 a) { return v3(s * a.x, s * a.y, s * a.z); }
INLINE V3 vdiv(V3 a, LF s) { return v3(a.x / s, a.y / s, a.z / s); }
INLINE V3 vneg(V3 a) { return v3(-a.x, -a.y, -a.z); }
INLINE LF vdot(V3 a, V3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
INLINE V3 vcross(V3 a, V3 b) { return v3(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x); }
/* correctly rounded: the same bits at every width (at width 1 common.h's sqrt_f: inline where clang is the compiler) */
#if LANES == 1 && defined(MF_SQRT_BUILTIN)
INLINE LF sqrt_l(LF x) { return __builtin_sqrtf(x); }
#else
INLINE LF sqrt_l(LF x) { return sqrt(x); }
#endif
INLINE V3 vunit(V3 a) { return vdiv(a, sqrt_l(vdot(a, a))); }
INLINE V3 vpick(LI m, V3 a, V3 b) { return v3(m ? a.x : b.x, m ? a.y : b.y, m ? a.z : b.z); }
/* x = e in the lanes of m, e computed only where some lane needs it (a masked pass: at width 1, the scalar branch);
 * WHERE3 for a V3 */
#define WHERE(m, x, e) if (ANY(m)) x = (m) ? (e) : (x)
#define WHERE3(m, x, e) if (ANY(m)) x = vpick((m), (e), (x))
INLINE LF abs_l(LF x) { return AS_LF(AS_LU(x) & 0x7fffffffU); }
/* i mod n in [0, n) (floored: -1 mod n is n - 1), for n > 0 and |i| < 2^24.  In lanes no integer division (a CPU has
 * none in vector lanes, and Intel's runtime calls a routine per lane for `%`): the float quotient's floor is off by at
 * most one there, and one step corrects it.  At width 1 `%` (the float form stops Intel's runtime vectorising the
 * wavefront's wave_shade across work-items: test_wavefront). */
INLINE LI mod_l(LI i, LI n) {
#if LANES == 1
    LI m = i % n;
#else
    LI m = i - CONVERT_I(floor(CONVERT_F(i) / CONVERT_F(n))) * n;
#endif
    m = m < 0 ? m + n : m;
    return m >= n ? m - n : m;
}
INLINE LF max_l(LF a, LF b) { return a > b ? a : b; }
INLINE LF min_l(LF a, LF b) { return a < b ? a : b; }
INLINE LF max3_l(V3 a) { return max_l(a.x, max_l(a.y, a.z)); }
INLINE LF clamp_l(LF x, float lo, float hi) { /* mathf.h's clamp_det: a NaN x gives lo */
    LF y = x > lo ? x : (LF)(lo);
    return y < hi ? y : (LF)(hi);
}
/* elements i, i + 1, i + 2 of b: a packed float3 per lane */
INLINE V3 gather3(__global const float *b, LI i) { return v3(gather(b, i), gather(b, i + 1), gather(b, i + 2)); }
/* atan2(y, x) as mathf.h's atan2_det gives it (C99's results for zeros, infinities and NaN): at width 1 ATAN2 (that
 * function in a DET_MATH program), in lanes its reduction and Cephes' polynomial, the special cases by selects */
INLINE LF atan2_l(LF y, LF x) {
#if LANES == 1
    return ATAN2(y, x);
#else
    LF ay = abs_l(y), ax = abs_l(x), t = ay / ax;
    LU sy = AS_LU(y) & 0x80000000U;
    LI x_neg = AS_LI(x) < 0; /* -0 counts as negative, as in C99 */
    LI big = t > 2.414213562f, mid = NOT(big) & (t > 0.4142135623f);
    LF base = big ? (LF)(MF_PIO2_HI) : mid ? (LF)(0.5f * MF_PIO2_HI) : (LF)(0.0f);
    LF base_lo = big ? (LF)(MF_PIO2_LO) : mid ? (LF)(0.5f * MF_PIO2_LO) : (LF)(0.0f);
    t = big ? -1.0f / t : mid ? (t - 1.0f) / (t + 1.0f) : t;
    LF z = t * t, p = MF_ATAN_POLY(z, t);
    LF a = base + ((p + base_lo) + t);
    a = x_neg ? MF_PI_HI - (a - MF_PI_LO) : a;
    LF at_infinity = ay == INFINITY ? (x_neg ? (LF)(2.35619450f) : (LF)(0.785398163f)) : (x_neg ? (LF)(MF_PI_HI) : (LF)(0.0f));
    a = ax == INFINITY ? at_infinity : a;
    a = (ax == 0.0f) | ((ay == INFINITY) & (ax < INFINITY)) ? (LF)(MF_PIO2_HI) : a;
    a = ay == 0.0f ? (x_neg ? (LF)(MF_PI_HI) : (LF)(0.0f)) : a;
    return (x != x) | (y != y) ? x + y : AS_LF(AS_LU(a) | sy);
#endif
}

/* acos(x) as mathf.h's acos_det gives it (NaN outside [-1, 1]): at width 1 ACOS, in lanes its two branches by a select */
INLINE LF acos_l(LF x) {
#if LANES == 1
    return ACOS(x);
#else
    LF a = abs_l(x), z = x * x, r = sqrt_l(0.5f * (1.0f - a)), w = r * r;
    LF near_zero = MF_PIO2_HI - (MF_ASIN_POLY(z, x) - MF_PIO2_LO), s = 2.0f * MF_ASIN_POLY(w, r);
    LF v = a <= 0.5f ? near_zero : (x > 0.0f ? s : MF_PI_HI - (s - MF_PI_LO));
    return a <= 1.0f ? v : (LF)(NAN);
#endif
}

/* e^x as mathf.h's exp_det gives it (0 below -103.97, inf above 88.72, NaN kept): at width 1 EXP, in lanes its steps
 * with the two scalings it takes near the ends of the range as selects */
INLINE LF exp_l(LF x) {
#if LANES == 1
    return EXP(x);
#else
    LF n = floor(x * 1.44269504f + 0.5f);
    LF r = (x - n * 0.693359375f) + n * 2.12194440e-4f, z = r * r, p = MF_EXP_POLY(r, z);
    LI k = CONVERT_I(clamp(n, -200.0f, 200.0f)), top = k > 127, bottom = k < -125;
    p = top ? p * 2.0f : (bottom ? p * 5.42101086e-20f : p);
    k = top ? k - 1 : (bottom ? k + 64 : k);
    LF v = p * AS_LF((k + 127) << 23);
    v = x < -103.972084f ? (LF)(0.0f) : v;
    v = x > 88.7228391f ? (LF)(INFINITY) : v;
    return x != x ? x : v;
#endif
}

/* a uniform 3-vector in every lane */
INLINE V3 splat3(float3 a) { return v3((LF)(a.x), (LF)(a.y), (LF)(a.z)); }

/* nextafter(x, INFINITY) and nextafter(x, -INFINITY) by the bits, inline (PoCL's is a call); the
 * same for every float: NaN and the infinity it heads for unchanged, +-0 to the smallest denormal
 * of that sign, others one ulp along. */
INLINE LF next_up(LF x) {
    LF y = AS_LF(AS_LI(x) + (x > 0.0f ? (LI)(1) : (LI)(-1)));
    y = x == 0.0f ? AS_LF((LI)(1)) : y;
    return x < INFINITY ? y : x; /* NaN, +inf */
}
INLINE LF next_down(LF x) {
    LF y = AS_LF(AS_LI(x) + (x > 0.0f ? (LI)(-1) : (LI)(1)));
    y = x == 0.0f ? AS_LF((LI)(0x80000001U)) : y;
    return x > -INFINITY ? y : x; /* NaN, -inf */
}

/* Where a ray leaving a surface point starts: p moved along the (unit) normal
 * n, on the side the new ray goes, just past p's float32 error box p_err
 * (pbrt-v4's OffsetRayOrigin), then rounded one more ulp away.  p_err comes
 * from how the hit point was computed (hit_point_triangle / _sphere), so the
 * offset is a few ulps of the coordinates: it scales with the scene and with
 * its distance from the origin, and never reaches a surface farther away than
 * that (a card 0.05 above a floor at 1e-3 scale still shadows it). */
INLINE V3 offset_origin(V3 p, V3 p_err, V3 n) {
    LF d = abs_l(n.x) * p_err.x + abs_l(n.y) * p_err.y + abs_l(n.z) * p_err.z;
    V3 offset = vscale(d, n);
    V3 po = vadd(p, offset);
    po.x = offset.x > 0.0f ? next_up(po.x) : (offset.x < 0.0f ? next_down(po.x) : po.x);
    po.y = offset.y > 0.0f ? next_up(po.y) : (offset.y < 0.0f ? next_down(po.y) : po.y);
    po.z = offset.z > 0.0f ? next_up(po.z) : (offset.z < 0.0f ? next_down(po.z) : po.z);
    return po;
}

/* lane k of a lane variable, to read or write: a scalar's own value at width 1 */
#if LANES == 1
#define LANE(v, k) (v)
#define LANE_I(v, k) (v)
#define LANE_U(v, k) (v)
#else
#define LANE(v, k) (((float *)&(v))[k])
#define LANE_I(v, k) (((int *)&(v))[k])
#define LANE_U(v, k) (((uint *)&(v))[k])
#endif

/* A probe's outputs, for the lanes whose item is below n: out[(base + k) stride] = lane k of v (element type T);
 * STORE_FLOAT4: the float4 out[(base + k) stride] = lane k of (x, y, z, w) */
#if LANES == 1
#define STORE_LANES(T, out, stride, base, n, v) ((out)[(base) * (stride)] = (v))
#define STORE_FLOAT4(out, stride, base, n, x, y, z, w) ((out)[(base) * (stride)] = (float4)(x, y, z, w))
#else
#define STORE_LANES(T, out, stride, base, n, v)                                                                 \
    do {                                                                                                        \
        T lanes_[LANES];                                                                                        \
        LANES_CAT(vstore, LANES)(v, 0, lanes_);                                                                 \
        for (int k_ = 0; k_ < LANES && (int)(base) + k_ < (int)(n); ++k_) (out)[((base) + k_) * (stride)] = lanes_[k_]; \
    } while (0)
#define STORE_FLOAT4(out, stride, base, n, x, y, z, w)                                          \
    do {                                                                                        \
        float x_[LANES], y_[LANES], z_[LANES], w_[LANES];                                       \
        LANES_CAT(vstore, LANES)(x, 0, x_);                                                     \
        LANES_CAT(vstore, LANES)(y, 0, y_);                                                     \
        LANES_CAT(vstore, LANES)(z, 0, z_);                                                     \
        LANES_CAT(vstore, LANES)(w, 0, w_);                                                     \
        for (int k_ = 0; k_ < LANES && (int)(base) + k_ < (int)(n); ++k_)                       \
            (out)[((base) + k_) * (stride)] = (float4)(x_[k_], y_[k_], z_[k_], w_[k_]);         \
    } while (0)
#endif

/* lanes set in m, counted */
INLINE int lanes_set(LI m) {
#if LANES == 1
    return m != 0;
#else
    int lane[LANES], n = 0;
    LANES_CAT(vstore, LANES)(m, 0, lane);
    for (int k = 0; k < LANES; ++k) n += lane[k] != 0;
    return n;
#endif
}

/* sin and cos of x, |x| < 256, as mathf.h's sincos_det gives them: at width 1 SINCOS (that function in a DET_MATH
 * program), in lanes its reduction (mf_reduce: |x| reduced, the sign put back) and Cephes' polynomials without its
 * branches */
INLINE void sincos_l(LF x, LF *s, LF *c) {
#if LANES == 1
    SINCOS(x, *s, *c);
#else
    LF a = abs_l(x);
    LI small = a <= 0.785398163f;
    LF n = small ? (LF)(0.0f) : floor(a * 0.636619772f + 0.5f);
    LF r = small ? x : MF_CODY_WAITE(a, n);
    LI q = CONVERT_I(n), negative = NOT(small) & (x < 0.0f);
    r = negative ? -r : r;
    q = (negative ? -q : q) & 3;
    LF z = r * r, ps = MF_SIN_POLY(r, z), pc = MF_COS_POLY(z);
    LI odd = (q & 1) != 0, flip_s = (q & 2) != 0, flip_c = ((q + 1) & 2) != 0;
    LF sv = odd ? pc : ps, cv = odd ? ps : pc;
    *s = flip_s ? -sv : sv;
    *c = flip_c ? -cv : cv;
#endif
}

#endif
