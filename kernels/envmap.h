/* The image-based environment light: lookup, density and importance sampling of an equirectangular map.
 * clrender/scene/environment.py states the mapping (Mitsuba 3's envmap: v = acos(d.y) / pi from +y,
 * u = atan2(d.x, -d.z) / 2 pi) and builds the distribution: texel weights luminance x sin(theta), a
 * marginal CDF over rows and a conditional CDF per row.  A texel's radiance is constant over it (nearest
 * lookup), so the density matches what is seen exactly. */
#ifndef ENVMAP_H
#define ENVMAP_H

#include "common.h"

#define ENV_INV_2PI2 0.0506605918f /* 1 / (2 pi^2): d omega = 2 pi^2 sin(theta) du dv */

/* A map as the kernels read it (layout.ENV_MAP_DTYPE and its buffers). */
typedef struct {
    EnvMap m;                          /* m.width 0: no map */
    __global const float4 *texels;     /* row-major: RGB radiance (intensity applied), w: density over (u, v) */
    __global const float *marginal;    /* height + 1 running sums over the rows */
    __global const float *conditional; /* height rows of width + 1 running sums */
} EnvView;

INLINE EnvView env_view(EnvMap m, __global const float4 *texels, __global const float *marginal, __global const float *conditional) {
    EnvView e;
    e.m = m; e.texels = texels; e.marginal = marginal; e.conditional = conditional;
    return e;
}

/* World direction to the map's frame: turned by -rotation about +y. */
INLINE float3 env_to_local(EnvMap m, float3 d) {
    return (float3)(m.cos_rotation * d.x - m.sin_rotation * d.z, d.y, m.sin_rotation * d.x + m.cos_rotation * d.z);
}

INLINE float3 env_to_world(EnvMap m, float3 l) {
    return (float3)(m.cos_rotation * l.x + m.sin_rotation * l.z, l.y, -m.sin_rotation * l.x + m.cos_rotation * l.z);
}

/* The texel a unit world direction falls in; sin_theta gets sin of its polar angle. */
INLINE int env_texel(EnvMap m, float3 d, float *sin_theta) {
    float3 l = env_to_local(m, d);
    float r = sqrt(l.x * l.x + l.z * l.z); /* theta by atan2, not acos(y): exact near the poles too */
    float u = atan2(l.x, -l.z) * (0.5f * M_1_PI_F), v = atan2(r, l.y) * M_1_PI_F;
    if (u < 0.0f) u += 1.0f;
    int col = min((int)(u * (float)m.width), m.width - 1), row = min((int)(v * (float)m.height), m.height - 1);
    *sin_theta = r / norm(l);
    return row * m.width + col;
}

/* Radiance from direction d (unit, world), and the solid-angle density with which env_sample picks it. */
INLINE float3 env_eval(const EnvView *e, float3 d, float *pdf) {
    float sin_theta;
    float4 t = e->texels[env_texel(e->m, d, &sin_theta)];
    *pdf = e->m.sampled && sin_theta > 0.0f ? t.w * ENV_INV_2PI2 / sin_theta : 0.0f;
    return t.xyz;
}

INLINE float3 env_radiance(const EnvView *e, float3 d) {
    float pdf;
    return env_eval(e, d, &pdf);
}

/* The interval of a running sum cdf[0 .. n] (0 ... 1) holding u in [0, 1): the largest i < n with cdf[i] <= u,
 * which skips empty intervals; *rest gets u's place inside it, in [0, 1). */
INLINE int cdf_search(__global const float *cdf, int n, float u, float *rest) {
    int lo = 0, hi = n - 1;
    while (lo < hi) {
        int mid = (lo + hi + 1) / 2;
        if (cdf[mid] <= u) lo = mid;
        else hi = mid - 1;
    }
    float width = cdf[lo + 1] - cdf[lo];
    *rest = width > 0.0f ? min_f((u - cdf[lo]) / width, 0x1.fffffep-1f) : 0.5f;
    return lo;
}

/* A direction drawn in proportion to luminance x solid angle (u in [0, 1)^2): its radiance and solid-angle density. */
INLINE float3 env_sample(const EnvView *e, float2 u, float3 *radiance, float *pdf) {
    float du, dv;
    int row = cdf_search(e->marginal, e->m.height, u.x, &dv);
    int col = cdf_search(e->conditional + row * (e->m.width + 1), e->m.width, u.y, &du);
    float theta = M_PI_F * ((float)row + dv) / (float)e->m.height, phi = 2.0f * M_PI_F * ((float)col + du) / (float)e->m.width;
    float sin_theta = sin(theta);
    float4 t = e->texels[row * e->m.width + col];
    *radiance = t.xyz;
    *pdf = sin_theta > 0.0f ? t.w * ENV_INV_2PI2 / sin_theta : 0.0f;
    return env_to_world(e->m, (float3)(sin_theta * sin(phi), cos(theta), -sin_theta * cos(phi)));
}

#endif
