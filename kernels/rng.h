/* Counter-based random numbers: a value depends only on (seed, pixel,
 * sample, dimension), never on work-group size, device or launch order.
 * Each step is written once and used for one value, for kernels/lanes.h's
 * lanes (a stream per path: Rng's fields are lane types, uint at width 1)
 * and for eight dimensions of one stream at once (uint8, float8: an area
 * light's samples in kernels/shade.h); integer steps are exact, so every
 * lane is bit for bit the one-value result. */
#ifndef CLRENDER_RNG_H
#define CLRENDER_RNG_H

#include "lanes.h"

/* The lowbias32 integer finaliser (Wellons): strong avalanche, cheap.  x: a uint or uint8 variable. */
#define MIX32_STEPS(x)                  \
    x ^= x >> 16; x *= 0x7feb352dU; \
    x ^= x >> 15; x *= 0x846ca68bU; \
    x ^= x >> 16

INLINE LU mix32(LU x) { MIX32_STEPS(x); return x; }
INLINE uint8 mix32_lanes(uint8 x) { MIX32_STEPS(x); return x; }

/* hash4's first three rounds: what every dimension d of one (a, b, c) stream shares */
INLINE LU hash3(LU a, LU b, LU c) {
    LU h = mix32(a + 0x9e3779b9U);
    h = mix32(h ^ (b + 0x85ebca6bU));
    return mix32(h ^ (c + 0xc2b2ae35U));
}

#define HASH_KEY_D 0x27d4eb2fU /* the last round's key, of hash4 and hash4_lanes alike */
INLINE LU hash4(LU a, LU b, LU c, LU d) { return mix32(hash3(a, b, c) ^ (d + HASH_KEY_D)); }

/* Uniform float in [0, 1) with 24 random bits: the top 24 bits of h, times 2^-24. */
#define U01_SCALE (1.0f / 16777216.0f)

/* u01 lane by lane: the same 24-bit integer, converted to float exactly as (float) does, by bit tricks
 * instead of convert_float8 (out of line on PoCL): q = 2 floor(q / 2) + (q & 1), and q >> 1 < 2^23 is the
 * mantissa of 2^23 + (q >> 1). */
#define U01_BITS(F, AS_F, h) /* the body of a function of h (a variable) returning F (float8...; AS_F: as_float8...) */ \
    h >>= 8;                                                                                                           \
    F halves = AS_F((h >> 1) | 0x4b000000u) - 8388608.0f; /* 0x4b000000: 2^23 = 8388608.0f */                        \
    F odd = (h & 1u) != 0u ? (F)(1.0f) : (F)(0.0f);                                                                    \
    return (halves * 2.0f + odd) * U01_SCALE
INLINE float8 u01_lanes(uint8 h) { U01_BITS(float8, as_float8, h); }
#if LANES == 1
INLINE LF u01(LU h) { return (float)(h >> 8) * U01_SCALE; }
#else
INLINE LF u01(LU h) { U01_BITS(LF, AS_LF, h); }
#endif

#ifndef RNG_SOBOL
#define RNG_SOBOL 0 /* 1: rng_next gives dimension `dim` of sample `sample` of the pixel's Sobol sequence (kernels/sobol.h) */
#endif

#if RNG_SOBOL
INLINE LU sobol_pixel_key(LU seed, LU pixel); /* kernels/sobol.h */
INLINE LU reverse_bits32(LU x);               /* kernels/sampling.h */
#endif

typedef struct {
    LU seed, pixel, sample, dim;
    LU base;  /* the current vertex's first dimension (rng_vertex, rng_slot) */
    LU extra; /* draws of rng_extra so far (their own dimensions, hashed) */
#if RNG_SOBOL
    LU key;   /* sobol.h's sobol_pixel_key(seed, pixel) */
    LU sample_reversed; /* the sample index bit-reversed, which every pair scrambles */
#endif
} Rng;

INLINE Rng make_rng(LU seed, LU pixel, LU sample) {
    Rng r;
    r.seed = seed; r.pixel = pixel; r.sample = sample; r.dim = 0; r.base = 0; r.extra = 0;
#if RNG_SOBOL
    r.key = sobol_pixel_key(seed, pixel); r.sample_reversed = reverse_bits32(sample);
#endif
    return r;
}

/* a in the lanes of m, b in the others */
INLINE Rng keep_rng(LI m, Rng a, Rng b) {
    Rng r;
    r.seed = m ? a.seed : b.seed; r.pixel = m ? a.pixel : b.pixel; r.sample = m ? a.sample : b.sample; r.dim = m ? a.dim : b.dim;
    r.base = m ? a.base : b.base; r.extra = m ? a.extra : b.extra;
#if RNG_SOBOL
    r.key = m ? a.key : b.key; r.sample_reversed = m ? a.sample_reversed : b.sample_reversed;
#endif
    return r;
}

#if RNG_SOBOL
INLINE LF sobol_value(const Rng *r);  /* kernels/sobol.h */
INLINE V2 sobol_value2(const Rng *r); /* kernels/sobol.h */
#endif

/* Next dimension of this (seed, pixel, sample) stream. */
INLINE LF rng_next(Rng *r) {
#if RNG_SOBOL
    LF x = sobol_value(r);
#else
    LF x = u01(hash4(r->seed, r->pixel, r->sample, r->dim));
#endif
    r->dim += 1;
    return x;
}

/* The next two dimensions, the first in x: a 2-D sample.  With RNG_SOBOL, from an even dimension, one pair of the
 * sequence, whose two coordinates share their pair's work (sobol.h): in lanes, where every lane's is even (the
 * numbers are the same either way). */
INLINE V2 rng_next2(Rng *r) {
#if RNG_SOBOL
    if (ALL((r->dim & 1U) == 0U)) {
        V2 x = sobol_value2(r);
        r->dim += 2;
        return x;
    }
#endif
    LF x = rng_next(r);
    LF y = rng_next(r);
    return v2(x, y);
}

/* A number whose place in the stream is not fixed (a stochastic alpha test draws one per layer it meets), drawn in the
 * lanes `on` (their counters move; at width 1 on is set): a hashed uniform number of its own counter, from dimension
 * RNG_EXTRA_DIMS on, so that however many are drawn, no dimension of the path's layout (rng_vertex) moves. */
#define RNG_EXTRA_DIMS 0x80000000U
INLINE LF rng_extra(Rng *r, LI on) {
    LF x = u01(hash4(r->seed, r->pixel, r->sample, RNG_EXTRA_DIMS | r->extra));
    r->extra = on ? r->extra + 1U : r->extra;
    return x;
}

/* The path tracer's dimensions (kernels/path.cl), the same for both samplers: the camera owns dimensions 0-1 (the pixel
 * offset) and 2-3 (the lens); bounce vertex `depth` owns VERTEX_DIMS dimensions from rng_vertex's base
 * VERTEX_DIMS (depth + 1) on, at fixed slots:
 *   SLOT_PICK 0      the material component      SLOT_RR 1          Russian roulette
 *   SLOT_BSDF 3      the lobe choice u1, then the BSDF's 2-D sample at 4-5
 *   SLOT_LIGHT 7     NEE's choice of one light (light_choice.h), then its 2-D sample at 8-9 (a point of an area
 *                    light or emissive triangle, a direction of the environment)
 * A 2-D sample starts at an even dimension, so that with the Sobol sampler its two numbers are one pair.  Fixed places
 * keep each draw's dimension whatever was drawn before it: a lane of render_path_lanes whose path skips a draw (a lobe
 * or a light it does not use) moves no later number, and the schedules may trace a vertex's rays in any order. */
#define VERTEX_DIMS (1U << 20)
#define SLOT_PICK 0U
#define SLOT_RR 1U
#define SLOT_BSDF 3U
#define SLOT_LIGHT 7U

INLINE void rng_vertex(Rng *r, LI depth) {
    r->base = VERTEX_DIMS * AS_LU(depth + 1);
    r->dim = r->base + SLOT_PICK;
}

INLINE void rng_slot(Rng *r, uint slot) { r->dim = r->base + slot; }

#if LANES == 1 /* the Whitted integrator's area lights: eight dimensions of one path's stream */
INLINE uint8 hash4_lanes(uint a, uint b, uint c, uint8 d) { return mix32_lanes((uint8)(hash3(a, b, c)) ^ (d + HASH_KEY_D)); }

/* Dimensions `dim` (one per lane) of this stream, as rng_next gives them; r->dim is left as it is. */
INLINE float8 rng_lanes(const Rng *r, uint8 dim) { return u01_lanes(hash4_lanes(r->seed, r->pixel, r->sample, dim)); }
#endif

#endif
