/* The path tracer's Sobol sampler (RenderSettings.path_sampler "sobol", -DRNG_SOBOL=1): dimension d of sample i
 * of a pixel is a coordinate of an Owen-scrambled, index-shuffled 2-D Sobol sequence, padded to any number of
 * dimensions (pbrt-v4's PaddedSobolSampler with "owen" randomisation; Burley 2020, "Practical Hash-based Owen
 * Scrambling", shuffled_scrambled_sobol2d).
 *
 *   - Dimensions come in pairs: pair p = d / 2, coordinate d % 2.  Coordinate 0 is the van der Corput sequence
 *     (the bit-reversed index), coordinate 1 the second Sobol dimension: together the (0,2)-sequence whose first
 *     2^m points put one point in every elementary interval of area 2^-m (a (0,m,2)-net).
 *   - Each pair has its own key, a hash of (seed, pixel, SOBOL_KEY_PAIR, p).  The key Owen-scrambles the sample
 *     index (a permutation that maps the first 2^m indices onto an aligned block of 2^m, so the first 2^m samples
 *     of every pair are still a (0,m,2)-net, while different pairs get unrelated orders), and, mixed with
 *     SOBOL_KEY_X or SOBOL_KEY_Y (sampling.h's), each coordinate's values.  Only the first two Sobol generator
 *     matrices are used; every pair beyond them is this padding, so no dimension falls off a table.
 *   - Integer arithmetic throughout, 32-bit indices: the same bits on every driver, tiling and split.
 *
 * What the path tracer's draws mean (path.cl): the camera owns dimensions 0-1 (the pixel offset) and 2-3 (the lens);
 * bounce vertex `depth` owns dimensions from rng_vertex's base VERTEX_DIMS (depth + 1) on, at fixed slots:
 *   SLOT_PICK 0      the material component      SLOT_RR 1          Russian roulette
 *   SLOT_BSDF 3      the lobe choice u1, then the BSDF's 2-D sample at 4-5
 *   SLOT_LIGHT 7     NEE's choice of one light (light_choice.h), then its 2-D sample at 8-9 (a point of an area
 *                    light or emissive triangle, a direction of the environment)
 * A 2-D sample starts at an even dimension, so its two numbers are one pair.  Stochastic alpha draws a variable
 * number per ray: those come from rng_extra (rng.h), hashed, outside these dimensions. */
#ifndef CLRENDER_SOBOL_H
#define CLRENDER_SOBOL_H

/* reverse_bits32, sobol_dim1, owen_scramble, SOBOL_KEY_Y */
#include "sampling.h"

#define SOBOL_KEY_PAIR 0x5eb01U /* hash4's third argument for a pair's key (the first two: seed, pixel; the last: the pair) */
#define SOBOL_KEY_X 0x3c6ef372U /* mixed into a pair's key for coordinate 0's scramble (SOBOL_KEY_Y for coordinate 1) */
#define VERTEX_DIMS (1U << 20)          /* dimensions a bounce vertex owns */
#define SLOT_PICK 0U
#define SLOT_RR 1U
#define SLOT_BSDF 3U
#define SLOT_LIGHT 7U

/* Sobol's second dimension without a table: its direction numbers are v_k = (1 + S)^k 2^31 (S: shift right by one),
 * and bit 31 - j of (1 + S)^k 2^31 is the binomial C(k, j) mod 2, which by Lucas's theorem is 1 exactly when j's bits are
 * a subset of k's.  So bit 31 - j of the point is the xor of index bits k over the supersets k of j: the subset-sum
 * (Moebius) transform over GF(2), five shift-and-mask steps for 32 bits, then a bit reversal.  sobol_second is
 * reverse_bits32(superset_xor(i)), bit for bit sampling.h's sobol_dim1 (one step per index bit). */
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

/* Coordinate c (0 or 1) of point i of the unscrambled 2-D Sobol sequence, as a 32-bit fraction. */
INLINE LU sobol_coordinate(LU i, LU c) { return c == 0U ? reverse_bits32(i) : sobol_second(i); }

/* sampling.h's owen_scramble between its bit reversals (a nested scramble of the reversed value). */
INLINE LU laine_karras(LU x, LU seed) {
    LAINE_KARRAS_STEPS(x, seed);
    return x;
}

/* A pixel's key, what every pair's key starts from: hash4's first three rounds of (seed, pixel, SOBOL_KEY_PAIR). */
INLINE LU sobol_pixel_key(LU seed, LU pixel) { return hash3(seed, pixel, SOBOL_KEY_PAIR); }

/* What both coordinates of pair `pair` of a sample share: the pair's key, hash4(seed, pixel, SOBOL_KEY_PAIR, pair), and
 * the sample's shuffled index i = reverse(owen_scramble(index, key)), from the index bit-reversed. */
typedef struct {
    LU key, i;
} SobolPair;
INLINE SobolPair sobol_pair(LU pixel_key, LU index_reversed, LU pair) {
    SobolPair q;
    q.key = mix32(pixel_key ^ (pair + HASH_KEY_D));
    q.i = reverse_bits32(laine_karras(index_reversed, q.key));
    return q;
}

/* Coordinate c of a pair's point, as a 32-bit fraction: owen_scramble(sobol_coordinate(i, c), the coordinate's key), with
 * the bit reversals that cancel left out (the coordinate reversed is i itself for c 0, superset_xor(i) for c 1). */
INLINE LU sobol_pair_coordinate(SobolPair q, LU c) {
    LU point_reversed = c == 0U ? q.i : superset_xor(q.i);
    return reverse_bits32(laine_karras(point_reversed, mix32(q.key ^ (c == 0U ? (LU)(SOBOL_KEY_X) : (LU)(SOBOL_KEY_Y)))));
}

/* Dimension `dim` of sample `index` of the pixel whose sobol_pixel_key is pixel_key, as a 32-bit fraction. */
INLINE LU sobol_bits(LU seed, LU pixel, LU index, LU dim) {
    return sobol_pair_coordinate(sobol_pair(sobol_pixel_key(seed, pixel), reverse_bits32(index), dim >> 1), dim & 1U);
}

#if RNG_SOBOL
INLINE LF sobol_value(const Rng *r) { return u01(sobol_pair_coordinate(sobol_pair(r->key, r->sample_reversed, r->dim >> 1), r->dim & 1U)); }
/* Both coordinates of the pair that starts at r->dim (even), sharing the pair's key and shuffled index. */
INLINE V2 sobol_value2(const Rng *r) {
    SobolPair q = sobol_pair(r->key, r->sample_reversed, r->dim >> 1);
    return v2(u01(sobol_pair_coordinate(q, 0U)), u01(sobol_pair_coordinate(q, 1U)));
}
#endif

/* The path tracer's dimension places (the table above).  For the independent sampler (RNG_SOBOL 0) they do nothing:
 * its numbers follow one another as they always did. */
INLINE void rng_vertex(Rng *r, LI depth) {
#if RNG_SOBOL
    r->base = VERTEX_DIMS * AS_LU(depth + 1);
    r->dim = r->base + SLOT_PICK;
#endif
}

INLINE void rng_slot(Rng *r, uint slot) {
#if RNG_SOBOL
    r->dim = r->base + slot;
#endif
}

#endif
