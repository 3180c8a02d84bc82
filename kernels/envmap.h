/* The image-based environment light: lookup, density and importance sampling of an equirectangular map.
 * clrender/scene/environment.py states the mapping (Mitsuba 3's envmap: v = acos(d.y) / pi from +y,
 * u = atan2(d.x, -d.z) / 2 pi) and builds the distribution: texel weights luminance x sin(theta), a
 * marginal CDF over rows and a conditional CDF per row.  The radiance is bilinear between texel centres as
 * Mitsuba 3's envmap reads it; the sampling density is constant over each cell between four texel centres
 * (weights: the mean of the four texels' luminance x sin(theta) at the cell's middle), so it is positive
 * wherever the radiance is, and env_eval returns that same piecewise-constant density for MIS. */
#ifndef ENVMAP_H
#define ENVMAP_H

#include "common.h"
#include "mathf.h"
#include "lanes.h"

#define ENV_INV_2PI2 0.0506605918f /* 1 / (2 pi^2): d omega = 2 pi^2 sin(theta) du dv */

/* A map as the kernels read it (layout.ENV_MAP_DTYPE and its buffers). */
typedef struct {
    EnvMap m;                          /* m.width 0: no map */
    __global const float4 *texels;     /* row-major: RGB radiance (intensity applied), w: density over (u, v) of
                                        * the cell whose top-left texel it is (0 on the last row) */
    __global const float *marginal;    /* height running sums over the height - 1 rows of cells */
    __global const float *conditional; /* height - 1 rows of width + 1 running sums */
    __global const int *guides;        /* the marginal's guide (m.row_buckets + 1), then each row's (m.column_buckets + 1) */
} EnvView;

INLINE EnvView env_view(EnvMap m, __global const float4 *texels, __global const float *marginal, __global const float *conditional,
                        __global const int *guides) {
    EnvView e;
    e.m = m; e.texels = texels; e.marginal = marginal; e.conditional = conditional; e.guides = guides;
    return e;
}

/* World direction to the map's frame: turned by -rotation about +y. */
INLINE V3 env_to_local(EnvMap m, V3 d) {
    return v3(m.cos_rotation * d.x - m.sin_rotation * d.z, d.y, m.sin_rotation * d.x + m.cos_rotation * d.z);
}

INLINE V3 env_to_world(EnvMap m, V3 l) {
    return v3(m.cos_rotation * l.x + m.sin_rotation * l.z, l.y, -m.sin_rotation * l.x + m.cos_rotation * l.z);
}

/* The map's (u, v) of a unit world direction; sin_theta gets sin of its polar angle. */
INLINE V2 env_uv(EnvMap m, V3 d, LF *sin_theta) {
    V3 l = env_to_local(m, d);
#if LANES == 1
    float r = SQRT(l.x * l.x + l.z * l.z); /* theta by atan2, not acos(y): exact near the poles too */
#else
    LF r = sqrt_l(l.x * l.x + l.z * l.z);
#endif
    LF u = atan2_l(l.x, -l.z) * (0.5f * M_1_PI_F), v = atan2_l(r, l.y) * M_1_PI_F;
    u = u < 0.0f ? u + 1.0f : u;
    *sin_theta = r / sqrt_l(vdot(l, l));
    return v2(u, v);
}

/* The cell between texel centres that (u, v) falls in (Mitsuba's envmap: column j's centre at u = (j + 1/2) / W,
 * wrapping; row i at v = i / (H - 1)): the index of its top-left texel, *col that texel's column, and *w (u, v)'s place
 * in it, in [0, 1]^2. */
INLINE LI env_cell(EnvMap m, V2 uv, LI *col_out, V2 *w) {
    LF x = uv.x * (float)m.width - 0.5f, y = uv.y * (float)(m.height - 1);
    LF fx = floor(x);
    LI col = CONVERT_I(fx), row = min(CONVERT_I(y), m.height - 2);
    col = col < 0 ? col + m.width : (col >= m.width ? col - m.width : col);
#if LANES > 1 /* a lane without a direction (NaN) reads texel 0, and nothing keeps it */
    col = clamp(col, (LI)(0), (LI)(m.width - 1));
    row = clamp(row, (LI)(0), (LI)(m.height - 2));
#endif
    *w = v2(clamp(x - fx, 0.0f, 1.0f), clamp(y - CONVERT_F(row), 0.0f, 1.0f));
    *col_out = col;
    return row * m.width + col;
}

/* texel i's radiance (xyz) and density (w) */
INLINE V3 env_texel(const EnvView *e, LI i) { return gather3((__global const float *)e->texels, 4 * i); }
INLINE LF env_density(const EnvView *e, LI i) { return gather((__global const float *)e->texels, 4 * i + 3); }

/* The radiance bilinearly interpolated in a cell (top-left texel `cell`, in column `col`) between its four texels (the
 * right column wraps). */
INLINE V3 env_bilinear(const EnvView *e, LI cell, LI col, V2 w) {
    int width = e->m.width;
    LI right = cell + (col + 1 < width ? (LI)(1) : (LI)(1 - width));
    V3 a = env_texel(e, cell), b = env_texel(e, right), c = env_texel(e, cell + width), d = env_texel(e, right + width);
    V3 top = v3((1.0f - w.x) * a.x + w.x * b.x, (1.0f - w.x) * a.y + w.x * b.y, (1.0f - w.x) * a.z + w.x * b.z);
    V3 bottom = v3((1.0f - w.x) * c.x + w.x * d.x, (1.0f - w.x) * c.y + w.x * d.y, (1.0f - w.x) * c.z + w.x * d.z);
    return v3((1.0f - w.y) * top.x + w.y * bottom.x, (1.0f - w.y) * top.y + w.y * bottom.y, (1.0f - w.y) * top.z + w.y * bottom.z);
}

/* Radiance from direction d (unit, world), and the solid-angle density with which env_sample picks it. */
INLINE V3 env_eval(const EnvView *e, V3 d, LF *pdf) {
    LF sin_theta;
    V2 w;
    LI col, cell = env_cell(e->m, env_uv(e->m, d, &sin_theta), &col, &w);
    LI counted = sin_theta > 0.0f;
    if (!e->m.sampled) counted = 0;
    *pdf = counted ? env_density(e, cell) * ENV_INV_2PI2 / sin_theta : (LF)(0.0f);
    return env_bilinear(e, cell, col, w);
}

INLINE V3 env_radiance(const EnvView *e, V3 d) {
    LF pdf;
    return env_eval(e, d, &pdf);
}

/* The interval of a running sum cdf[0 .. n] (0 ... 1), at cdf + at, holding u in [0, 1): the largest i < n with
 * cdf[i] <= u, which skips empty intervals; *rest gets u's place inside it, in [0, 1).  The search starts from the
 * sum's guide (at guide + guide_at; clrender/scene/environment.py guide: entry k the interval of k / buckets), whose
 * entries k and k + 1 bound the answer for u in bucket k = floor(u buckets), exact for a power of two: one or two
 * intervals for most u, where a search of the whole sum takes log2 n dependent loads.  The i with cdf[i] <= u are a
 * prefix (the sum never decreases): the search halves the range that holds its last one, [lo, lo + len), by a select,
 * not a branch (which way a random u goes is a coin toss); in lanes, until every lane's range is one interval. */
INLINE LI cdf_search(__global const float *cdf, LI at, __global const int *guide, LI guide_at, int buckets, LF u, LF *rest) {
    LI k = min(CONVERT_I(u * (float)buckets), buckets - 1);
    k = k > 0 ? k : (LI)(0); /* never read before the guide, whatever u is */
    LI lo = gather_i(guide, guide_at + k);
    for (LI len = gather_i(guide, guide_at + k + 1) - lo + 1; ANY(len > 1);) {
        LI step = len >> 1; /* len > 0: a shift, where Intel's runtime calls a routine for a lane division */
        LI further = (len > 1) & (gather(cdf, at + lo + step) <= u);
        lo = further ? lo + step : lo;
        len = len > 1 ? len - step : len;
    }
    LF low = gather(cdf, at + lo), width = gather(cdf, at + lo + 1) - low;
    *rest = width > 0.0f ? min_l((u - low) / width, 0x1.fffffep-1f) : (LF)(0.5f);
    return lo;
}

/* A direction drawn in proportion to the cells' weights x solid angle (u in [0, 1)^2): its radiance and solid-angle
 * density.  A cell is picked by the marginal CDF over its H - 1 rows and its row's conditional CDF, then a uniform
 * point inside it, whose radiance is the bilinear one at that point. */
INLINE V3 env_sample(const EnvView *e, V2 u, V3 *radiance, LF *pdf) {
    LF du, dv;
    LI row = cdf_search(e->marginal, 0, e->guides, 0, e->m.row_buckets, u.x, &dv);
    LI col = cdf_search(e->conditional, row * (e->m.width + 1), e->guides, (e->m.row_buckets + 1) + row * (e->m.column_buckets + 1),
                        e->m.column_buckets, u.y, &du);
    LF uu = (CONVERT_F(col) + 0.5f + du) / (float)e->m.width;
    uu = uu >= 1.0f ? uu - 1.0f : uu;
    LF theta = M_PI_F * (CONVERT_F(row) + dv) / (float)(e->m.height - 1), phi = 2.0f * M_PI_F * uu;
    LF sin_theta, cos_theta, sin_phi, cos_phi;
    sincos_l(theta, &sin_theta, &cos_theta);
    sincos_l(phi, &sin_phi, &cos_phi);
    LI cell = row * e->m.width + col;
    *radiance = env_bilinear(e, cell, col, v2(du, dv));
    *pdf = sin_theta > 0.0f ? env_density(e, cell) * ENV_INV_2PI2 / sin_theta : (LF)(0.0f);
    return env_to_world(e->m, v3(sin_theta * sin_phi, cos_theta, -sin_theta * cos_phi));
}

#endif
