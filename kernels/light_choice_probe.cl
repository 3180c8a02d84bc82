/* Test-only kernel: light_choice.h's pick over a batch, for tests through clrender/trace/light_choice.py (picks). */
#include "common.h"
#include "rng.h"
#include "light_choice.h"

/* out[i] = the record picked by the first random number of stream (seed, i, 0), as path.cl draws its pick */
__kernel void light_pick_probe(int n, uint seed, __global const LightChoice *choices, int n_choices, __global int *out) {
    int i = get_global_id(0);
    if (i >= n) return;
    Rng rng = make_rng(seed, (uint)i, 0U);
    out[i] = pick_light_of(choices, n_choices, rng_next(&rng));
}
