/* Test-only kernel: light_choice.h's pick over a batch, for tests through clrender/trace/light_choice.py (picks).  Built
 * at LANES 1 (one pick a work-item, as path.cl picks) or 8 or 16 (one in each lane), which give the same picks. */
#define DET_MATH 1
#include "mathf.h"
#include "common.h"
#include "rng.h"
#include "light_choice.h"

/* out[i] = the record picked by the first random number of stream (seed, i, 0), as path.cl draws its pick */
__kernel void light_pick_probe(int n, uint seed, __global const LightChoice *choices, int n_choices, __global int *out) {
    int base = get_global_id(0) * LANES;
    if (base >= n) return;
    LU i = min((LU)(base) + LANE_IDS_L, (LU)(n - 1));
    Rng rng = make_rng((LU)(seed), i, (LU)(0U));
    STORE_LANES(int, out, 1, base, n, pick_light_of(choices, n_choices, rng_next(&rng)));
}
