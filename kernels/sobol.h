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
 * Which dimension each of the path tracer's draws takes: rng.h (rng_vertex, rng_slot; a 2-D sample starts at an even
 * dimension, so its two numbers are one pair). */
#ifndef CLRENDER_SOBOL_H
#define CLRENDER_SOBOL_H

/* reverse_bits32, sobol_second, owen_scramble, SOBOL_KEY_Y */
#include "sampling.h"

#define SOBOL_KEY_PAIR 0x5eb01U /* hash4's third argument for a pair's key (the first two: seed, pixel; the last: the pair) */
#define SOBOL_KEY_X 0x3c6ef372U /* mixed into a pair's key for coordinate 0's scramble (SOBOL_KEY_Y for coordinate 1) */

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

#endif
