/* Test-only kernel: kernels/sobol.h's sequence over a batch of (pixel, sample) points, for tests/kernels/test_sobol.py
 * (through clrender/trace/sampling.py sequence_points). */
#define RNG_SOBOL 1
#include "layout.h"
#include "rng.h"
#include "sobol.h"

/* out[(g * n_dims + k)]: dimension dims[k] of sample first + g % n_samples of pixel pixels[g / n_samples], as the
 * 32-bit fraction (scrambled 1: sobol_bits with `seed`; 0: the unscrambled Sobol coordinate dims[k] % 2 of the index) */
__kernel void sobol_probe(__global const uint *pixels, uint n_samples, uint first, uint n_work, __global const uint *dims,
                          uint n_dims, uint seed, int scrambled, __global uint *out) {
    uint g = get_global_id(0);
    if (g >= n_work) return;
    uint pixel = pixels[g / n_samples], index = first + g % n_samples;
    for (uint k = 0; k < n_dims; ++k) {
        uint d = dims[k];
        out[(size_t)g * n_dims + k] = scrambled ? sobol_bits(seed, pixel, index, d) : sobol_coordinate(index, d & 1U);
    }
}
