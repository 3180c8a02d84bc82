/* Test-only kernels: kernels/sobol.h's sequence over a batch of (pixel, sample) points, for
 * tests/trace/test_path_sampler.py (through clrender/trace/sampling.py sequence_points and path_draws).  Built at
 * LANES 1 (one point a work-item) or 8 or 16 (that many points a work-item, one in each lane), which give the same
 * bits. */
#define RNG_SOBOL 1
#define DET_MATH 1
#include "layout.h"
#include "rng.h"
#include "sobol.h"

/* the work-item's points, g .. g + LANES - 1; lanes past the last point repeat it and are not stored */
INLINE LU probe_points(uint n_work) { return min((LU)(get_global_id(0) * LANES) + LANE_IDS_L, (LU)(n_work - 1U)); }

/* out[g * n + k] = v for the work-item's points g below n_work */
#define PUT_LANES(out, T, n_work, n, k, v) STORE_LANES(T, (out) + (k), n, get_global_id(0) * LANES, n_work, v)

/* out[(g * n_dims + k)]: dimension dims[k] of sample first + g % n_samples of pixel pixels[g / n_samples], as the
 * 32-bit fraction (scrambled 1: sobol_bits with `seed`; 0: the unscrambled Sobol coordinate dims[k] % 2 of the index) */
__kernel void sobol_probe(__global const uint *pixels, uint n_samples, uint first, uint n_work, __global const uint *dims,
                          uint n_dims, uint seed, int scrambled, __global uint *out) {
    if (get_global_id(0) * LANES >= n_work) return;
    LU g = probe_points(n_work);
    LU pixel = gather_u(pixels, g / n_samples), index = first + g % n_samples;
    for (uint k = 0; k < n_dims; ++k) {
        uint d = dims[k];
        LU v = scrambled ? sobol_bits((LU)(seed), pixel, index, (LU)(d)) : sobol_coordinate(index, (LU)(d & 1U));
        PUT_LANES(out, uint, n_work, n_dims, k, v);
    }
}

/* The path tracer's draws at vertices 0 .. depth - 1 of sample first + g % n_samples of pixel pixels[g / n_samples],
 * through its Rng as path.cl takes them: at each vertex rng_vertex, then the component's pick (SLOT_PICK), Russian
 * roulette's (SLOT_RR), the BSDF's u1 and 2-D sample (SLOT_BSDF), the light's pick and 2-D sample (SLOT_LIGHT), and
 * one rng_extra.  out[(g * depth + vertex) * PATH_DRAWS + k], in that order. */
#define PATH_DRAWS 9
__kernel void path_draws_probe(__global const uint *pixels, uint n_samples, uint first, uint n_work, uint depth, uint seed,
                               __global float *out) {
    if (get_global_id(0) * LANES >= n_work) return;
    LU g = probe_points(n_work);
    Rng r = make_rng((LU)(seed), gather_u(pixels, g / n_samples), first + g % n_samples);
    for (uint v = 0; v < depth; ++v) {
        LF draws[PATH_DRAWS];
        rng_vertex(&r, (LI)(v));
        draws[0] = rng_next(&r);
        rng_slot(&r, SLOT_RR);
        draws[1] = rng_next(&r);
        rng_slot(&r, SLOT_BSDF);
        draws[2] = rng_next(&r);
        V2 u2 = rng_next2(&r);
        draws[3] = u2.x;
        draws[4] = u2.y;
        rng_slot(&r, SLOT_LIGHT);
        draws[5] = rng_next(&r);
        V2 ul = rng_next2(&r);
        draws[6] = ul.x;
        draws[7] = ul.y;
        draws[8] = rng_extra(&r, ALL_LANES);
        for (uint k = 0; k < PATH_DRAWS; ++k) PUT_LANES(out, float, n_work, depth * PATH_DRAWS, v * PATH_DRAWS + k, draws[k]);
    }
}
