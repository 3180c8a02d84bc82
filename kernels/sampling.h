/* Where the samples of a pixel and of an area light fall.
 * Offsets are in [0, 1)^2 from the pixel's top-left corner; sample s of N*N
 * has sub-square row p = s / N (vertical) and column q = s % N (horizontal). */
#ifndef CLRENDER_SAMPLING_H
#define CLRENDER_SAMPLING_H

#include "rng.h"

inline uint reverse_bits32(uint x) {
    x = ((x >> 1) & 0x55555555U) | ((x & 0x55555555U) << 1);
    x = ((x >> 2) & 0x33333333U) | ((x & 0x33333333U) << 2);
    x = ((x >> 4) & 0x0F0F0F0FU) | ((x & 0x0F0F0F0FU) << 4);
    x = ((x >> 8) & 0x00FF00FFU) | ((x & 0x00FF00FFU) << 8);
    return (x >> 16) | (x << 16);
}

/* Second Sobol dimension (the first is the bit-reversed index). */
inline uint sobol_dim1(uint i) {
    uint r = 0;
    for (uint v = 1U << 31; i; i >>= 1, v ^= v >> 1)
        if (i & 1U) r ^= v;
    return r;
}

/* Owen scrambling by Laine and Karras's hash (with Burley's constants):
 * keeps the points stratified while decorrelating neighbouring pixels. */
inline uint owen_scramble(uint x, uint seed) {
    x = reverse_bits32(x);
    x += seed;
    x ^= x * 0x6c50b47cU;
    x ^= x * 0xb82f1e52U;
    x ^= x * 0xc7afe638U;
    x ^= x * 0x8d22f6e6U;
    return reverse_bits32(x);
}

inline float2 pixel_sample_offset(int sampler, uint s, uint n, Rng *rng) {
    float p = (float)(s / n), q = (float)(s % n), fn = (float)n;
    if (sampler == SAMPLER_UNIFORM) {
        /* the seed's fixed grid: (p + 0.5) / n */
        return (float2)((q + 0.5f) / fn, (p + 0.5f) / fn);
    }
    if (sampler == SAMPLER_RANDOM) {
        float x = rng_next(rng);
        float y = rng_next(rng);
        return (float2)(x, y);
    }
    if (sampler == SAMPLER_STRATIFIED) {
        /* one jittered sample in each of the n x n sub-squares */
        float x = rng_next(rng);
        float y = rng_next(rng);
        return (float2)((q + x) / fn, (p + y) / fn);
    }
    /* scrambled Sobol: the first n*n points of a (0,2)-sequence, per-pixel Owen scramble */
    uint key = hash4(rng->seed, rng->pixel, 0x50B01U, 0U);
    uint x = owen_scramble(reverse_bits32(s), key);
    uint y = owen_scramble(sobol_dim1(s), mix32(key ^ 0x68bc21ebU));
    rng->dim += 2; /* keep later dimensions aligned with the other samplers */
    return (float2)(u01(x), u01(y));
}

/* Point on a parallelogram light.  Stratified (the seed): corner + (p+xi)/n a
 * + (q+xi')/n b, one jittered point per cell.  Random: corner + xi a + xi' b,
 * ignoring the cells (kept to show what stratification buys). */
inline float3 area_light_point(float3 corner, float3 a, float3 b, uint p, uint q, uint n, bool stratified, Rng *rng) {
    float xi_a = rng_next(rng);
    float xi_b = rng_next(rng);
    if (!stratified) return corner + xi_a * a + xi_b * b;
    float fn = (float)n;
    return corner + ((float)p + xi_a) / fn * a + ((float)q + xi_b) / fn * b;
}

#endif
