/* The path tracer's reconstruction filters (Mitsuba 3's film): a sample at image position (x, y) counts towards
 * every pixel whose centre lies within the filter's radius, with weight f(x - cx) f(y - cy), and a pixel is the
 * sum of its weighted samples over the sum of their weights.  clrender/trace/film.py names them and gathers the
 * splats; docs/command-line.md (--filter) states the formulas.  Built with SPLAT_FILTER (FILM_FILTER_* code) and
 * SPLAT_RADIUS (the footprint's half width in whole pixels) from film.py's defines. */
#ifndef FILM_H
#define FILM_H

#include "mathf.h"
#include "lanes.h"

#define FILM_FILTER_TENT 1         /* f(x) = max(0, 1 - |x| / r), r = 1 px (Mitsuba's `tent`) */
#define FILM_FILTER_GAUSSIAN 2     /* f(x) = max(0, exp(-x^2 / (2 s^2)) - exp(-r^2 / (2 s^2))), s = 0.5 px, r = 4 s */
#define FILM_TENT_RADIUS 1.0f
#define FILM_GAUSSIAN_STDDEV 0.5f
#define FILM_GAUSSIAN_RADIUS 2.0f  /* 4 standard deviations */

/* The filter's weight at signed distance x (pixels) from a pixel centre (a lane's: kernels/lanes.h). */
INLINE LF film_weight(int filter, LF x) {
    if (filter == FILM_FILTER_TENT) return fmax(0.0f, 1.0f - fabs(x) / FILM_TENT_RADIUS);
    float alpha = -1.0f / (2.0f * FILM_GAUSSIAN_STDDEV * FILM_GAUSSIAN_STDDEV);
    return fmax(0.0f, exp_l(alpha * x * x) - EXP(alpha * FILM_GAUSSIAN_RADIUS * FILM_GAUSSIAN_RADIUS));
}

#endif
