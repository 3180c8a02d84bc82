/* Counter-based random numbers: a value depends only on (seed, pixel,
 * sample, dimension), never on work-group size, device or launch order. */
#ifndef CLRENDER_RNG_H
#define CLRENDER_RNG_H

/* The lowbias32 integer finaliser (Wellons): strong avalanche, cheap. */
INLINE uint mix32(uint x) {
    x ^= x >> 16; x *= 0x7feb352dU;
    x ^= x >> 15; x *= 0x846ca68bU;
    x ^= x >> 16;
    return x;
}

INLINE uint hash4(uint a, uint b, uint c, uint d) {
    uint h = mix32(a + 0x9e3779b9U);
    h = mix32(h ^ (b + 0x85ebca6bU));
    h = mix32(h ^ (c + 0xc2b2ae35U));
    return mix32(h ^ (d + 0x27d4eb2fU));
}

/* Uniform float in [0, 1) with 24 random bits. */
INLINE float u01(uint h) { return (float)(h >> 8) * (1.0f / 16777216.0f); }

typedef struct {
    uint seed, pixel, sample, dim;
} Rng;

INLINE Rng make_rng(uint seed, uint pixel, uint sample) {
    Rng r;
    r.seed = seed; r.pixel = pixel; r.sample = sample; r.dim = 0;
    return r;
}

/* Next dimension of this (seed, pixel, sample) stream. */
INLINE float rng_next(Rng *r) {
    float x = u01(hash4(r->seed, r->pixel, r->sample, r->dim));
    r->dim += 1;
    return x;
}

#endif
