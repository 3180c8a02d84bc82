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
INLINE float3 env_to_local(EnvMap m, float3 d) {
    return (float3)(m.cos_rotation * d.x - m.sin_rotation * d.z, d.y, m.sin_rotation * d.x + m.cos_rotation * d.z);
}

INLINE float3 env_to_world(EnvMap m, float3 l) {
    return (float3)(m.cos_rotation * l.x + m.sin_rotation * l.z, l.y, -m.sin_rotation * l.x + m.cos_rotation * l.z);
}

/* The map's (u, v) of a unit world direction; sin_theta gets sin of its polar angle. */
INLINE float2 env_uv(EnvMap m, float3 d, float *sin_theta) {
    float3 l = env_to_local(m, d);
    float r = SQRT(l.x * l.x + l.z * l.z); /* theta by atan2, not acos(y): exact near the poles too */
    float u = ATAN2(l.x, -l.z) * (0.5f * M_1_PI_F), v = ATAN2(r, l.y) * M_1_PI_F;
    if (u < 0.0f) u += 1.0f;
    *sin_theta = r / norm(l);
    return (float2)(u, v);
}

/* The cell between texel centres that (u, v) falls in (Mitsuba's envmap: column j's centre at u = (j + 1/2) / W,
 * wrapping; row i at v = i / (H - 1)): the index of its top-left texel, and *w (u, v)'s place in it, in [0, 1]^2. */
INLINE int env_cell(EnvMap m, float2 uv, float2 *w) {
    float x = uv.x * (float)m.width - 0.5f, y = uv.y * (float)(m.height - 1);
    float fx = floor(x);
    int col = (int)fx, row = min((int)y, m.height - 2);
    col = col < 0 ? col + m.width : (col >= m.width ? col - m.width : col);
    *w = (float2)(clamp(x - fx, 0.0f, 1.0f), clamp(y - (float)row, 0.0f, 1.0f));
    return row * m.width + col;
}

/* The radiance bilinearly interpolated in a cell between its four texels (the right column wraps). */
INLINE float3 env_bilinear(const EnvView *e, int cell, float2 w) {
    int width = e->m.width, col = cell % width;
    int right = cell + (col + 1 < width ? 1 : 1 - width);
    float3 top = (1.0f - w.x) * e->texels[cell].xyz + w.x * e->texels[right].xyz;
    float3 bottom = (1.0f - w.x) * e->texels[cell + width].xyz + w.x * e->texels[right + width].xyz;
    return (1.0f - w.y) * top + w.y * bottom;
}

/* Radiance from direction d (unit, world), and the solid-angle density with which env_sample picks it. */
INLINE float3 env_eval(const EnvView *e, float3 d, float *pdf) {
    float sin_theta;
    float2 w;
    int cell = env_cell(e->m, env_uv(e->m, d, &sin_theta), &w);
    *pdf = e->m.sampled && sin_theta > 0.0f ? e->texels[cell].w * ENV_INV_2PI2 / sin_theta : 0.0f;
    return env_bilinear(e, cell, w);
}

INLINE float3 env_radiance(const EnvView *e, float3 d) {
    float pdf;
    return env_eval(e, d, &pdf);
}

/* The interval of a running sum cdf[0 .. n] (0 ... 1) holding u in [0, 1): the largest i < n with cdf[i] <= u,
 * which skips empty intervals; *rest gets u's place inside it, in [0, 1).  The search starts from the sum's guide
 * (clrender/scene/environment.py guide: entry k the interval of k / buckets), whose entries k and k + 1 bound the
 * answer for u in bucket k = floor(u buckets), exact for a power of two: one or two intervals for most u, where a
 * search of the whole sum takes log2 n dependent loads.  The i with cdf[i] <= u are a prefix (the sum never
 * decreases): the search halves the range that holds its last one, [lo, lo + len), by a select, not a branch
 * (which way a random u goes is a coin toss). */
INLINE int cdf_search(__global const float *cdf, __global const int *guide, int buckets, float u, float *rest) {
    int k = min((int)(u * (float)buckets), buckets - 1);
    k = k > 0 ? k : 0; /* never read before the guide, whatever u is */
    int lo = guide[k];
    for (int len = guide[k + 1] - lo + 1; len > 1;) {
        int step = len / 2;
        lo = cdf[lo + step] <= u ? lo + step : lo;
        len -= step;
    }
    float width = cdf[lo + 1] - cdf[lo];
    *rest = width > 0.0f ? min_f((u - cdf[lo]) / width, 0x1.fffffep-1f) : 0.5f;
    return lo;
}

/* A direction drawn in proportion to the cells' weights x solid angle (u in [0, 1)^2): its radiance and solid-angle
 * density.  A cell is picked by the marginal CDF over its H - 1 rows and its row's conditional CDF, then a uniform
 * point inside it, whose radiance is the bilinear one at that point. */
INLINE float3 env_sample(const EnvView *e, float2 u, float3 *radiance, float *pdf) {
    float du, dv;
    int row = cdf_search(e->marginal, e->guides, e->m.row_buckets, u.x, &dv);
    int col = cdf_search(e->conditional + row * (e->m.width + 1),
                         e->guides + (e->m.row_buckets + 1) + row * (e->m.column_buckets + 1), e->m.column_buckets, u.y, &du);
    float uu = ((float)col + 0.5f + du) / (float)e->m.width;
    if (uu >= 1.0f) uu -= 1.0f;
    float theta = M_PI_F * ((float)row + dv) / (float)(e->m.height - 1), phi = 2.0f * M_PI_F * uu;
    float sin_theta, cos_theta, sin_phi, cos_phi;
    SINCOS(theta, sin_theta, cos_theta);
    SINCOS(phi, sin_phi, cos_phi);
    int cell = row * e->m.width + col;
    *radiance = env_bilinear(e, cell, (float2)(du, dv));
    *pdf = sin_theta > 0.0f ? e->texels[cell].w * ENV_INV_2PI2 / sin_theta : 0.0f;
    return env_to_world(e->m, (float3)(sin_theta * sin_phi, cos_theta, -sin_theta * cos_phi));
}

#endif
