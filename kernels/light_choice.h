/* Next-event estimation's one light a vertex (kernels/path.cl direct_lighting): a light picked in proportion to its
 * power from the host's LightChoice records (clrender/trace/light_choice.py), each its probability and the running
 * sum; kernels/light_choice_probe.cl runs the pick for the tests. */
#ifndef CLRENDER_LIGHT_CHOICE_H
#define CLRENDER_LIGHT_CHOICE_H

#include "lanes.h"

/* The record of u's place in the running sums of the n records: the first whose cdf exceeds u (binary search; the
 * last light that can be chosen has cdf 1, so every u in [0, 1) finds one of probability > 0).  In lanes, each lane's
 * search until every lane's has ended. */
INLINE LI pick_light_of(__global const LightChoice *choices, int n, LF u) {
    LI lo = 0, hi = n - 1;
    while (ANY(lo < hi)) {
        LI searching = lo < hi, mid = (lo + hi) >> 1; /* lo, hi >= 0: a shift (Intel's runtime calls a routine for a lane division) */
        LI below = u < FIELD_F(choices, mid, cdf);
        hi = searching & below ? mid : hi;
        lo = searching & NOT(below) ? mid + 1 : lo;
    }
    return lo;
}

#endif
