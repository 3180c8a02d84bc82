/* The spot light's angular profile (OpenCL C 1.2; Light record of clrender/layout.py, scene/lights.py packs it).
 * A spot is a point light at `position` whose radiant intensity along unit d (from the light) is
 * intensity * colour * spot_profile(d), falling off as 1 / r^2.  theta is d's angle to the axis `direction`:
 *   SPOT_PROFILE_MITSUBA  Mitsuba 3's spot.cpp: 1 within beam_width, (cutoff - theta) / (cutoff - beam) between,
 *                         0 from cutoff_angle on (linear in the angle, not its cosine)
 *   SPOT_PROFILE_PBRT     pbrt-v4's SpotLight: smoothstep(cos theta, cos cutoff, cos beam), pbrt's coneangle as
 *                         cutoff and coneangle - conedelta as beam */
#ifndef CLRENDER_SPOT_H
#define CLRENDER_SPOT_H

#include "mathf.h"

INLINE float spot_profile(__global const Light *L, float3 d) {
    float cos_theta = dot3(d, unit(vload3(0, L->direction)));
    if (L->spot_profile == SPOT_PROFILE_PBRT) {
        float lo = L->spot_cos_cutoff, hi = L->spot_cos_beam;
        if (!(hi > lo)) return cos_theta < lo ? 0.0f : 1.0f; /* no transition band: a hard edge */
        float t = clamp((cos_theta - lo) / (hi - lo), 0.0f, 1.0f);
        return t * t * (3.0f - 2.0f * t);
    }
    if (!(cos_theta > L->spot_cos_cutoff)) return 0.0f;
    if (cos_theta >= L->spot_cos_beam) return 1.0f;
    return (L->spot_cutoff - ACOS(cos_theta)) / (L->spot_cutoff - L->spot_beam);
}

#endif
