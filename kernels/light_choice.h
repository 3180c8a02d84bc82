/* Next-event estimation's one light a vertex (kernels/path.cl direct_lighting): a light picked in proportion to its
 * power from the host's LightChoice records (clrender/trace/light_choice.py), each its probability and the running
 * sum; kernels/light_choice_probe.cl runs the pick for the tests. */
#ifndef CLRENDER_LIGHT_CHOICE_H
#define CLRENDER_LIGHT_CHOICE_H

/* The record of u's place in the running sums of the n records: the first whose cdf exceeds u (binary search; the
 * last light that can be chosen has cdf 1, so every u in [0, 1) finds one of probability > 0). */
INLINE int pick_light_of(__global const LightChoice *choices, int n, float u) {
    int lo = 0, hi = n - 1;
    while (lo < hi) {
        int mid = (lo + hi) / 2;
        if (u < choices[mid].cdf) hi = mid;
        else lo = mid + 1;
    }
    return lo;
}

#endif
