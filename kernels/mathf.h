/* Deterministic float32 math: the same bits on every conforming OpenCL driver, inline, no builtin calls.
 *
 * The builtins' sin, cos, exp, log, atan2, acos, pow are each driver's own (OpenCL 1.2 allows them 2-4 ulp of
 * error, and PoCL's, Intel's and Oclgrind's differ in the last bits), and some drivers call them (and sqrt,
 * floor, clamp) out of line, spilling every live vector register.  The functions here use only +, -, *, /,
 * conversions between float and int, and bit operations, each of which IEEE 754 rounds exactly (or which is
 * exact), in a fixed order: so every driver computes the same bits, given two rules:
 *   - no contraction: a * b + c must not become an fma on one driver and two roundings on another, so a file
 *     that defines DET_MATH (path.cl, the probes) turns FP_CONTRACT off for the whole program, here;
 *   - / and sqrt correctly rounded: so they are on every CPU (divss, sqrtss); OpenCL 1.2 lets a GPU driver
 *     give 2.5 ulp for / and 3 ulp for sqrt unless the program is built with
 *     -cl-fp32-correctly-rounded-divide-sqrt (docs/math.md).
 *
 * Build switch DET_MATH (0 or undefined: off).  The headers shared with the Whitted kernels (camera.h, sampling.h,
 * envmap.h, spot.h) call SIN, COS, SINCOS, EXP, ATAN2, ACOS, SQRT, which are these functions in a DET_MATH program
 * and the builtins otherwise, so the Whitted kernels (trace.cl, which does not define DET_MATH) keep their bits.
 *
 * Error bounds, against float64 (ulp: of the float32 nearest the exact value; measured by
 * tests/kernels/test_mathf.py over each function's whole range, and stated there):
 *   sin_det, cos_det   <= 2.5 ulp where |result| >= 2^-12, else <= 2^-35 absolute; any finite x (Payne-Hanek
 *                      reduction past |x| = 256), NaN for +-inf and NaN
 *   sincos_det         both at once (sin_det and cos_det are its halves)
 *   exp_det            <= 2 ulp (denormal results: <= 1 ulp of the smallest denormal); +inf past 88.72, 0 below -103.98
 *   log_det            <= 2 ulp; -inf at +-0, NaN below 0, denormals exact in their exponent
 *   atan2_det          <= 3 ulp, with C99's results for zeros and infinities
 *   acos_det, asin_det <= 3 ulp
 *   pow_det            <= 2 + 2 |y ln x| ulp (exp(y log x): log's error grows with y); C99's special cases.
 *                      Not used by the path tracer.
 *   floor_det, clamp_det, sqrt_det  exact (clamp_det: fmin(fmax(x, lo), hi), a NaN x gives lo). */
#ifndef CLRENDER_MATHF_H
#define CLRENDER_MATHF_H

#include "layout.h"

/* clang's __builtin_sqrtf, the IEEE square root inline (sqrt_det; lanes.h's sqrt_l at width 1) */
#if defined(__has_builtin)
#if __has_builtin(__builtin_sqrtf)
#define MF_SQRT_BUILTIN 1
#endif
#endif

#if DET_MATH
#pragma OPENCL FP_CONTRACT OFF

INLINE float mf_abs(float x) { return as_float(as_uint(x) & 0x7fffffffu); }

#define MF_PIO2_HI 1.57079637f    /* pi / 2 rounded; MF_PIO2_LO its remainder */
#define MF_PIO2_LO (-4.37113883e-8f)
#define MF_PI_HI 3.14159274f
#define MF_PI_LO (-8.74227766e-8f)

/* floor by conversion: (int)x truncates exactly for |x| < 2^23; the sign bit kept so floor(-0) is -0 */
INLINE float floor_det(float x) {
    if (!(as_uint(x) << 1 < (150u << 24))) return x; /* |x| >= 2^23 (already whole), inf, NaN */
    float t = (float)(int)x;
    if (t > x) t -= 1.0f;
    return as_float(as_uint(t) | (as_uint(x) & 0x80000000u));
}

INLINE float clamp_det(float x, float lo, float hi) {
    float y = x > lo ? x : lo;
    return y < hi ? y : hi;
}

/* the IEEE square root (correctly rounded), inline where the compiler is clang (as common.h's sqrt_f) */
#ifdef MF_SQRT_BUILTIN
INLINE float sqrt_det(float x) { return __builtin_sqrtf(x); }
#else
INLINE float sqrt_det(float x) { return sqrt(x); }
#endif

/* 2/pi's bits, 32 a word, after a zero word (Payne-Hanek reads a 96-bit window starting up to 31 bits early) */
__constant uint MF_TWO_OVER_PI[9] = {0u,          0xA2F9836Eu, 0x4E441529u, 0xFC2757D1u, 0xF534DDC0u,
                                      0xDB629599u, 0x3C439041u, 0xFE5163ABu, 0xDEBBC561u};

INLINE uint mf_window(int w, int b) { /* 32 bits of the table at bit offset 32 w + b, b in [0, 32) */
    return b == 0 ? MF_TWO_OVER_PI[w] : (MF_TWO_OVER_PI[w] << b) | (MF_TWO_OVER_PI[w + 1] >> (32 - b));
}

/* |x| = q pi/2 + r, |r| <= pi/4 (about), for finite |x| >= 2^-30: Payne and Hanek's reduction in integers.
 * x = m 2^k (m: 24-bit integer); x 2/pi mod 4 needs 2/pi's bits from k - 1 on; 96 of them times m give
 * the quadrant in bits 94-95 and the fraction in bits 0-93, of which 64 are kept (a 2^-64 grain: the
 * closest a float32 comes to a multiple of pi/2 is far larger). */
INLINE float mf_reduce_big(uint ix, int *q) {
    int k = (int)(ix >> 23) - 150;
    ulong m = (ulong)((ix & 0x7fffffu) | 0x800000u);
    int q0 = 30 + k;
    int w = q0 >> 5, b = q0 & 31;
    ulong p0 = m * mf_window(w, b), p1 = m * mf_window(w + 1, b), p2 = m * mf_window(w + 2, b);
    ulong t = (p2 >> 32) + (p1 & 0xffffffffUL);
    uint mid1 = (uint)t;
    t = (t >> 32) + (p1 >> 32) + (p0 & 0xffffffffUL);
    uint mid2 = (uint)t;
    *q = (int)(mid2 >> 30);
    ulong f = ((ulong)(mid2 & 0x3fffffffu) << 34) | ((ulong)mid1 << 2) | ((ulong)(uint)p2 >> 30);
    long fs = (long)f; /* the fraction in [-1/2, 1/2), units of 2^-64: the quadrant rounded to nearest */
    if (fs < 0) *q += 1;
    float hi = (float)(int)(fs >> 40) * 5.96046448e-8f;                 /* its top 24 bits, exactly (2^-24) */
    float lo = (float)(int)((fs >> 9) & 0x7fffffffL) * 2.77555756e-17f; /* the next 31, rounded (2^-55) */
    return hi * MF_PIO2_HI + (lo * MF_PIO2_HI + hi * MF_PIO2_LO);
}

/* a - n pi/2 for a < 256: pi/2 in three parts, the first two short, so n * part is exact (Cody and Waite).  The
 * macros here are expressions over float or float vectors (lanes: kernels/lanes_probe.cl). */
#define MF_CODY_WAITE(a, n) ((((a) - (n) * 1.5703125f) - (n) * 4.83751296997e-4f) - (n) * 7.54978995e-8f)

/* x = q pi/2 + r, |r| <= pi/4 (about), q mod 4 */
INLINE float mf_reduce(float x, int *q) {
    float a = mf_abs(x), r;
    if (a <= 0.785398163f) {
        *q = 0;
        return x;
    }
    if (a < 256.0f) {
        float n = floor_det(a * 0.636619772f + 0.5f);
        r = MF_CODY_WAITE(a, n);
        *q = (int)n;
    } else {
        r = mf_reduce_big(as_uint(a), q);
    }
    if (x < 0.0f) {
        r = -r;
        *q = -*q;
    }
    *q &= 3;
    return r;
}

/* sin and cos on [-pi/4, pi/4]: Cephes' sinf and cosf polynomials (Moshier), of r and z = r * r */
#define MF_SIN_POLY(r, z) ((r) + (r) * (z) * ((8.3321608736e-3f - 1.9515295891e-4f * (z)) * (z) - 1.6666654611e-1f))
#define MF_COS_POLY(z)                                                                                                 \
    (1.0f - 0.5f * (z) + (z) * (z) * ((2.443315711809948e-5f * (z) - 1.388731625493765e-3f) * (z) + 4.166664568298827e-2f))
INLINE float mf_sin_poly(float r) {
    float z = r * r;
    return MF_SIN_POLY(r, z);
}
INLINE float mf_cos_poly(float r) {
    float z = r * r;
    return MF_COS_POLY(z);
}

/* sin x, with cos x in *c: one reduction for both */
INLINE float sincos_det(float x, float *c) {
    if (!(mf_abs(x) < INFINITY)) { /* NaN for +-inf and NaN */
        *c = x - x;
        return x - x;
    }
    int q;
    float r = mf_reduce(x, &q);
    float ps = mf_sin_poly(r), pc = mf_cos_poly(r);
    float s = (q & 1) ? pc : ps, co = (q & 1) ? ps : pc;
    *c = ((q + 1) & 2) ? -co : co;
    return (q & 2) ? -s : s;
}

INLINE float sin_det(float x) {
    float c;
    return sincos_det(x, &c);
}

INLINE float cos_det(float x) {
    float c;
    sincos_det(x, &c);
    return c;
}

/* 2^n for n in [-126, 127] by its bits */
INLINE float mf_pow2i(int n) { return as_float((uint)(n + 127) << 23); }

/* e^x = 2^n e^r, n = round(x / ln 2), r = x - n ln 2 (ln 2 in two parts) in [-ln2/2, ln2/2]: Cephes' expf */
#define MF_EXP_POLY(r, z)                                                                                              \
    ((((((1.9875691500e-4f * (r) + 1.3981999507e-3f) * (r) + 8.3334519073e-3f) * (r) + 4.1665795894e-2f) * (r) +      \
       1.6666665459e-1f) * (r) + 5.0000001201e-1f) * (z) + (r) + 1.0f)
INLINE float exp_det(float x) {
    if (x != x) return x;
    if (x > 88.7228391f) return INFINITY;
    if (x < -103.972084f) return 0.0f;
    float n = floor_det(x * 1.44269504f + 0.5f);
    float r = (x - n * 0.693359375f) + n * 2.12194440e-4f;
    float z = r * r;
    float p = MF_EXP_POLY(r, z);
    int k = (int)n;
    if (k > 127) { /* e^r < 1 near the top: 2^128 e^r in two exact steps */
        p *= 2.0f;
        k -= 1;
    }
    if (k < -125) { /* a denormal result: one rounding, in the last product */
        p *= 5.42101086e-20f; /* 2^-64, exact */
        k += 64;
    }
    return p * mf_pow2i(k);
}

/* ln x = e ln 2 + ln m, m in [sqrt(1/2), sqrt(2)): Cephes' logf, ln 2 in two parts */
INLINE float log_det(float x) {
    if (x != x || x == INFINITY) return x;
    if (x == 0.0f) return -INFINITY;
    if (x < 0.0f) return NAN;
    int e = 0;
    if (x < 1.17549435e-38f) { /* denormal: scale by 2^25 first */
        x *= 33554432.0f;
        e = -25;
    }
    uint ix = as_uint(x);
    e += (int)(ix >> 23) - 126;
    float m = as_float((ix & 0x007fffffu) | 0x3f000000u); /* [1/2, 1) */
    if (m < 0.707106781f) {
        e -= 1;
        m = m + m - 1.0f;
    } else {
        m = m - 1.0f;
    }
    float z = m * m;
    float y = ((((((((7.0376836292e-2f * m - 1.1514610310e-1f) * m + 1.1676998740e-1f) * m - 1.2420140846e-1f) * m +
                   1.4249322787e-1f) * m - 1.6668057665e-1f) * m + 2.0000714765e-1f) * m - 2.4999993993e-1f) * m +
              3.3333331174e-1f) * m * z;
    float fe = (float)e;
    y = y - 2.12194440e-4f * fe;
    y = y - 0.5f * z;
    return (m + y) + 0.693359375f * fe;
}

/* Cephes' atanf polynomial in t, z = t * t (lanes: kernels/lanes.h atan2_l) */
#define MF_ATAN_POLY(z, t) ((((8.05374449538e-2f * (z) - 1.38776856032e-1f) * (z) + 1.99777106478e-1f) * (z) - 3.33329491539e-1f) * (z) * (t))
/* atan of t >= 0 (inf included): Cephes' atanf, reduced about tan(pi/8) and tan(3 pi/8) */
INLINE float mf_atan_pos(float t) {
    float base = 0.0f, base_lo = 0.0f;
    if (t > 2.414213562f) {
        base = MF_PIO2_HI;
        base_lo = MF_PIO2_LO;
        t = -1.0f / t;
    } else if (t > 0.4142135623f) {
        base = 0.5f * MF_PIO2_HI;
        base_lo = 0.5f * MF_PIO2_LO;
        t = (t - 1.0f) / (t + 1.0f);
    }
    float z = t * t;
    float p = MF_ATAN_POLY(z, t);
    return base + ((p + base_lo) + t);
}

INLINE float atan2_det(float y, float x) {
    if (x != x || y != y) return x + y;
    float ay = mf_abs(y), ax = mf_abs(x), a;
    uint sy = as_uint(y) & 0x80000000u;
    int x_neg = (int)(as_uint(x) >> 31); /* -0 counts as negative, as in C99 */
    if (ay == 0.0f) {
        a = x_neg ? MF_PI_HI : 0.0f;
    } else if (ax == 0.0f || (ay == INFINITY && ax < INFINITY)) {
        a = MF_PIO2_HI;
    } else if (ax == INFINITY) {
        a = ay == INFINITY ? (x_neg ? 2.35619450f : 0.785398163f) : (x_neg ? MF_PI_HI : 0.0f);
    } else {
        a = mf_atan_pos(ay / ax);
        if (x_neg) a = MF_PI_HI - (a - MF_PI_LO);
    }
    return as_float(as_uint(a) | sy);
}

/* asin on [-1/2, 1/2]: Cephes' asinf polynomial (of t, z = t * t; lanes: kernels/lanes.h acos_l) */
#define MF_ASIN_POLY(z, t)                                                                                             \
    (((((4.2163199048e-2f * (z) + 2.4181311049e-2f) * (z) + 4.5470025998e-2f) * (z) + 7.4953002686e-2f) * (z) +       \
      1.6666752422e-1f) * (z) * (t) + (t))
INLINE float mf_asin_poly(float t) {
    float z = t * t;
    return MF_ASIN_POLY(z, t);
}

INLINE float asin_det(float x) {
    float a = mf_abs(x);
    if (!(a <= 1.0f)) return NAN; /* NaN too */
    if (a <= 0.5f) return mf_asin_poly(x);
    float v = MF_PIO2_HI - (2.0f * mf_asin_poly(sqrt_det(0.5f * (1.0f - a))) - MF_PIO2_LO);
    return x < 0.0f ? -v : v;
}

INLINE float acos_det(float x) {
    float a = mf_abs(x);
    if (!(a <= 1.0f)) return NAN;
    if (a <= 0.5f) return MF_PIO2_HI - (mf_asin_poly(x) - MF_PIO2_LO);
    float s = 2.0f * mf_asin_poly(sqrt_det(0.5f * (1.0f - a)));
    return x > 0.0f ? s : MF_PI_HI - (s - MF_PI_LO);
}

/* 0: y not a whole number, 1: odd, 2: even (|y| >= 2^24 is even) */
INLINE int mf_parity(float y) {
    if (floor_det(y) != y) return 0;
    if (mf_abs(y) >= 16777216.0f) return 2;
    return ((int)y & 1) ? 1 : 2;
}

INLINE float pow_det(float x, float y) {
    if (y == 0.0f || x == 1.0f) return 1.0f;
    if (x != x || y != y) return x + y;
    if (y == 1.0f) return x;
    float ax = mf_abs(x), ay = mf_abs(y);
    int parity = mf_parity(y);
    if (ay == INFINITY) {
        if (ax == 1.0f) return 1.0f;
        return (ax > 1.0f) == (y > 0.0f) ? INFINITY : 0.0f;
    }
    float v;
    if (ax == 0.0f || ax == INFINITY) {
        v = (ax == 0.0f) == (y < 0.0f) ? INFINITY : 0.0f;
    } else {
        if (x < 0.0f && parity == 0) return NAN;
        v = exp_det(y * log_det(ax));
    }
    return (x < 0.0f || as_uint(x) == 0x80000000u) && parity == 1 ? -v : v;
}

#define SIN(x) sin_det(x)
#define COS(x) cos_det(x)
#define SINCOS(x, s, c) ((s) = sincos_det((x), &(c))) /* s = SIN(x), c = COS(x) */
#define EXP(x) exp_det(x)
#define LOG(x) log_det(x)
#define ATAN2(y, x) atan2_det(y, x)
#define ACOS(x) acos_det(x)
#define POW(x, y) pow_det(x, y)
#define FLOOR(x) floor_det(x)
#define CLAMP(x, lo, hi) clamp_det(x, lo, hi)
#define SQRT(x) sqrt_det(x)
#else /* the builtins, as the Whitted kernels always called them */
#define SIN(x) sin(x)
#define COS(x) cos(x)
#define SINCOS(x, s, c) ((s) = sin(x), (c) = cos(x))
#define EXP(x) exp(x)
#define LOG(x) log(x)
#define ATAN2(y, x) atan2(y, x)
#define ACOS(x) acos(x)
#define POW(x, y) pow(x, y)
#define FLOOR(x) floor(x)
#define CLAMP(x, lo, hi) clamp(x, lo, hi)
#define SQRT(x) sqrt(x)
#endif

#endif
