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
#include "lanes.h"

INLINE LF spot_profile(__global const Light *lights, LI li, V3 d) {
    LF cos_theta = vdot(d, vunit(FIELD3(lights, li, direction)));
    LI pbrt = FIELD_I(lights, li, spot_profile) == SPOT_PROFILE_PBRT;
    LF lo = FIELD_F(lights, li, spot_cos_cutoff), hi = FIELD_F(lights, li, spot_cos_beam), profile = 0.0f;
    if (ANY(pbrt)) {
        LF t = clamp((cos_theta - lo) / (hi - lo), 0.0f, 1.0f);
        LF edge = cos_theta < lo ? (LF)(0.0f) : (LF)(1.0f); /* no transition band: a hard edge */
        profile = pbrt ? (hi > lo ? t * t * (3.0f - 2.0f * t) : edge) : profile;
    }
    LI linear = NOT(pbrt) & (cos_theta > lo) & NOT(cos_theta >= hi);
    profile = NOT(pbrt) & (cos_theta > lo) & (cos_theta >= hi) ? (LF)(1.0f) : profile;
    LF cutoff = FIELD_F(lights, li, spot_cutoff), beam = FIELD_F(lights, li, spot_beam);
    WHERE(linear, profile, (cutoff - acos_l(cos_theta)) / (cutoff - beam));
    return profile;
}

#endif
