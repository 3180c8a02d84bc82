/* Where the samples of a pixel and of an area light fall.
 * Offsets are in [0, 1)^2 from the pixel's top-left corner; sample s of N*N
 * has sub-square row p = s / N (vertical) and column q = s % N (horizontal). */
#ifndef CLRENDER_SAMPLING_H
#define CLRENDER_SAMPLING_H

/* the PIXEL_FILTER_* codes */
#include "layout.h"
#include "rng.h"
#include "mathf.h"

/* Bit reversal by a byte table: compilers turn the shift-and-mask idiom into
 * an llvm.bitreverse intrinsic that some OpenCL implementations (Oclgrind)
 * cannot run.  In lanes (kernels/lanes.h), by shifts and masks: a table
 * lookup per lane would be sixteen loads. */
__constant uchar REVERSED_BYTE[256] = {
    0x00, 0x80, 0x40, 0xc0, 0x20, 0xa0, 0x60, 0xe0, 0x10, 0x90, 0x50, 0xd0, 0x30, 0xb0, 0x70, 0xf0,
    0x08, 0x88, 0x48, 0xc8, 0x28, 0xa8, 0x68, 0xe8, 0x18, 0x98, 0x58, 0xd8, 0x38, 0xb8, 0x78, 0xf8,
    0x04, 0x84, 0x44, 0xc4, 0x24, 0xa4, 0x64, 0xe4, 0x14, 0x94, 0x54, 0xd4, 0x34, 0xb4, 0x74, 0xf4,
    0x0c, 0x8c, 0x4c, 0xcc, 0x2c, 0xac, 0x6c, 0xec, 0x1c, 0x9c, 0x5c, 0xdc, 0x3c, 0xbc, 0x7c, 0xfc,
    0x02, 0x82, 0x42, 0xc2, 0x22, 0xa2, 0x62, 0xe2, 0x12, 0x92, 0x52, 0xd2, 0x32, 0xb2, 0x72, 0xf2,
    0x0a, 0x8a, 0x4a, 0xca, 0x2a, 0xaa, 0x6a, 0xea, 0x1a, 0x9a, 0x5a, 0xda, 0x3a, 0xba, 0x7a, 0xfa,
    0x06, 0x86, 0x46, 0xc6, 0x26, 0xa6, 0x66, 0xe6, 0x16, 0x96, 0x56, 0xd6, 0x36, 0xb6, 0x76, 0xf6,
    0x0e, 0x8e, 0x4e, 0xce, 0x2e, 0xae, 0x6e, 0xee, 0x1e, 0x9e, 0x5e, 0xde, 0x3e, 0xbe, 0x7e, 0xfe,
    0x01, 0x81, 0x41, 0xc1, 0x21, 0xa1, 0x61, 0xe1, 0x11, 0x91, 0x51, 0xd1, 0x31, 0xb1, 0x71, 0xf1,
    0x09, 0x89, 0x49, 0xc9, 0x29, 0xa9, 0x69, 0xe9, 0x19, 0x99, 0x59, 0xd9, 0x39, 0xb9, 0x79, 0xf9,
    0x05, 0x85, 0x45, 0xc5, 0x25, 0xa5, 0x65, 0xe5, 0x15, 0x95, 0x55, 0xd5, 0x35, 0xb5, 0x75, 0xf5,
    0x0d, 0x8d, 0x4d, 0xcd, 0x2d, 0xad, 0x6d, 0xed, 0x1d, 0x9d, 0x5d, 0xdd, 0x3d, 0xbd, 0x7d, 0xfd,
    0x03, 0x83, 0x43, 0xc3, 0x23, 0xa3, 0x63, 0xe3, 0x13, 0x93, 0x53, 0xd3, 0x33, 0xb3, 0x73, 0xf3,
    0x0b, 0x8b, 0x4b, 0xcb, 0x2b, 0xab, 0x6b, 0xeb, 0x1b, 0x9b, 0x5b, 0xdb, 0x3b, 0xbb, 0x7b, 0xfb,
    0x07, 0x87, 0x47, 0xc7, 0x27, 0xa7, 0x67, 0xe7, 0x17, 0x97, 0x57, 0xd7, 0x37, 0xb7, 0x77, 0xf7,
    0x0f, 0x8f, 0x4f, 0xcf, 0x2f, 0xaf, 0x6f, 0xef, 0x1f, 0x9f, 0x5f, 0xdf, 0x3f, 0xbf, 0x7f, 0xff};

#if LANES == 1
INLINE uint reverse_bits32(uint x) {
    return ((uint)REVERSED_BYTE[x & 0xffU] << 24) | ((uint)REVERSED_BYTE[(x >> 8) & 0xffU] << 16) |
           ((uint)REVERSED_BYTE[(x >> 16) & 0xffU] << 8) | (uint)REVERSED_BYTE[x >> 24];
}
#else
INLINE LU reverse_bits32(LU x) {
    x = ((x >> 1) & 0x55555555U) | ((x & 0x55555555U) << 1);
    x = ((x >> 2) & 0x33333333U) | ((x & 0x33333333U) << 2);
    x = ((x >> 4) & 0x0f0f0f0fU) | ((x & 0x0f0f0f0fU) << 4);
    x = ((x >> 8) & 0x00ff00ffU) | ((x & 0x00ff00ffU) << 8);
    return (x >> 16) | (x << 16);
}
#endif

/* Second Sobol dimension (the first is the bit-reversed index). */
INLINE uint sobol_dim1(uint i) {
    uint r = 0;
    for (uint v = 1U << 31; i; i >>= 1, v ^= v >> 1)
        if (i & 1U) r ^= v;
    return r;
}

/* Sobol's second dimension without a table: its direction numbers are v_k = (1 + S)^k 2^31 (S: shift right by one),
 * and bit 31 - j of (1 + S)^k 2^31 is the binomial C(k, j) mod 2, which by Lucas's theorem is 1 exactly when j's bits are
 * a subset of k's.  So bit 31 - j of the point is the xor of index bits k over the supersets k of j: the subset-sum
 * (Moebius) transform over GF(2), five shift-and-mask steps for 32 bits, then a bit reversal.  sobol_second is
 * reverse_bits32(superset_xor(i)), bit for bit sobol_dim1 above (one step per index bit). */
#define SUPERSET_XOR_STEPS(x) /* x: a uint variable or a vector of them */ \
    x ^= (x >> 1) & 0x55555555U;                                           \
    x ^= (x >> 2) & 0x33333333U;                                           \
    x ^= (x >> 4) & 0x0f0f0f0fU;                                           \
    x ^= (x >> 8) & 0x00ff00ffU;                                           \
    x ^= (x >> 16) & 0x0000ffffU
INLINE LU superset_xor(LU x) {
    SUPERSET_XOR_STEPS(x);
    return x;
}
INLINE LU sobol_second(LU i) { return reverse_bits32(superset_xor(i)); }

/* Laine and Karras's permutation with Burley's constants, on x, a uint variable or a vector of them (lanes: the
 * probe kernels/lanes_probe.cl): bit k of the result depends on bits 0..k of x only. */
#define LAINE_KARRAS_STEPS(x, seed) \
    x += (seed);                    \
    x ^= x * 0x6c50b47cU;           \
    x ^= x * 0xb82f1e52U;           \
    x ^= x * 0xc7afe638U;           \
    x ^= x * 0x8d22f6e6U

/* Owen scrambling by that permutation of the reversed bits: keeps the points stratified while decorrelating
 * neighbouring pixels. */
INLINE LU owen_scramble(LU x, LU seed) {
    x = reverse_bits32(x);
    LAINE_KARRAS_STEPS(x, seed);
    return reverse_bits32(x);
}

/* A pixel's Owen scramble keys: hash4 of (seed, pixel, SOBOL_KEY_SAMPLE, 0), where the sample index would go a
 * value beyond any (at most 64 x 64 samples), so the key is no sample's random number; the y dimension's key is
 * that key mixed with SOBOL_KEY_Y. */
#define SOBOL_KEY_SAMPLE 0x50B01U
#define SOBOL_KEY_Y 0x68bc21ebU

INLINE V2 pixel_sample_offset(int sampler, LU s, uint n, Rng *rng) {
    if (sampler == SAMPLER_RANDOM) return rng_next2(rng);
#if LANES == 1
    float p = (float)(s / n), q = (float)(s % n), fn = (float)n;
#else /* each lane's sample s (s < 2^24): its column by mod_l, its row by an exact division */
    LI column = mod_l(AS_LI(s), (LI)((int)n));
    LF fn = (float)n, q = CONVERT_F(column), p = CONVERT_F(AS_LI(s) - column) / fn;
#endif
    if (sampler == SAMPLER_UNIFORM) {
        /* the centred grid: (p + 0.5) / n */
        return v2((q + 0.5f) / fn, (p + 0.5f) / fn);
    }
    if (sampler == SAMPLER_STRATIFIED) {
        /* one jittered sample in each of the n x n sub-squares */
        LF x = rng_next(rng);
        LF y = rng_next(rng);
        return v2((q + x) / fn, (p + y) / fn);
    }
    /* scrambled Sobol: the first n*n points of a (0,2)-sequence, per-pixel Owen scramble */
    LU key = hash4(rng->seed, rng->pixel, SOBOL_KEY_SAMPLE, 0U);
    LU x = owen_scramble(reverse_bits32(s), key);
#if LANES == 1
    uint y = owen_scramble(sobol_dim1(s), mix32(key ^ SOBOL_KEY_Y));
#else
    LU y = owen_scramble(sobol_second(s), mix32(key ^ SOBOL_KEY_Y));
#endif
    rng->dim += 2; /* keep later dimensions aligned with the other samplers */
    return v2(u01(x), u01(y));
}

/* Weight of a sample at `off` in [0,1)^2 within its pixel: box (all equal, the
 * default), tent (1 - 2|dx|)(1 - 2|dy|) or Gaussian (sigma 0.25 px) about the
 * pixel centre.  Samples stay inside their own pixel. */
#define TENT_FLOOR 1e-6f            /* added to every tent weight: a pixel whose samples all lie on its border keeps weight */
#define GAUSSIAN_FILTER_SIGMA 0.25f /* px, as docs/shading.md states it */
INLINE LF pixel_filter_weight(int filter, V2 off) {
    LF dx = off.x - 0.5f, dy = off.y - 0.5f;
    if (filter == PIXEL_FILTER_TENT) return (1.0f - 2.0f * fabs(dx)) * (1.0f - 2.0f * fabs(dy)) + TENT_FLOOR;
    if (filter == PIXEL_FILTER_GAUSSIAN) return exp_l(-(dx * dx + dy * dy) / (2.0f * GAUSSIAN_FILTER_SIGMA * GAUSSIAN_FILTER_SIGMA));
    return 1.0f;
}

#endif
