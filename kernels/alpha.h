/* What rays look past, for both integrators: glTF alphaMode, and (camera rays) single-sided back faces.
 * glTF alphaMode: a point's coverage alpha (the material's factor times its base colour
 * texture's alpha there) and what a ray does with it.
 *   MASK:  the point is there where alpha >= alphaCutoff, else every ray (camera, bounce, shadow) goes on past it.
 *   BLEND: the path tracer keeps the point with probability alpha (stochastic transparency, point_kept); the
 *          Whitted integrator, which draws no random numbers for its rays, blends instead: a camera or bounce
 *          ray sees alpha x the surface + (1 - alpha) x what lies behind it, and a shadow ray crossing the point
 *          keeps (1 - alpha) + alpha x transparency of the light (docs/materials.md).
 * Compiled only into the -DALPHA_TEST=1 and -DCULL_BACKFACES=1 variants (renderer.py builds them for scenes
 * with alpha-tested, single-sided materials): every other scene keeps the kernels it had, bit for bit. */
#ifndef CLRENDER_ALPHA_H
#define CLRENDER_ALPHA_H

#include "common.h"
#include "intersect.h"
#include "texture.h"
#include "surface.h"
#include "rng.h"

#ifndef ALPHA_TEST
#define ALPHA_TEST 0 /* 1: some material is alpha-tested (renderer.py): rays look past the points it leaves out */
#endif
#ifndef CULL_BACKFACES
#define CULL_BACKFACES 0 /* 1: some material is single-sided (glTF doubleSided false): camera rays look past its back faces */
#endif
#define LOOK_PAST (ALPHA_TEST || CULL_BACKFACES) /* camera rays may be traced again past a hit */
#define ALPHA_LAYERS 16 /* alpha-rejected surfaces one ray looks past; a ray that meets more stops at the next */

#if CULL_BACKFACES
/* Whether camera ray (o, d) does not see hit h (a hit: h.id >= 0 in every lane): the back face (the side away from the
 * winding's or a sphere's outward normal) of a single-sided material, a mask (kernels/lanes.h; render_path_lanes
 * tests its lanes' hits at once).  glTF: "When this value is false, back-face culling is enabled"; only camera rays
 * cull (docs/materials.md#double-sided): bounce and shadow rays see both faces. */
INLINE LI back_culled(const Geometry *g, TextureView tv, HitL h, V3 o, V3 d) {
    LI two_sided = FIELD_I(tv.materials, FIELD_I(g->objects, hit_object(g, h), material), double_sided) != 0;
    if (ALL(two_sided)) return 0;
    V3 p_err, n;
    LI sphere;
    hit_surface(g, h, o, d, &p_err, &n, &sphere);
    return NOT(two_sided) & (vdot(d, n) > 0.0f);
}
#endif

#if ALPHA_TEST
/* Hit h's material (each lane's), and its coverage there in *alpha (1 for opaque materials: no lookup;
 * kernels/surface.h's coverage_at).  A miss's lanes must read a hit (render_path_lanes gives them primitive 0).  The
 * fields are read in place: a private copy of the 256-byte record, in every inlined look-past loop, overflowed PoCL's
 * stack at 64-item groups (issue 38, defect 0; docs/materials.md#alpha-modes). */
INLINE LI hit_coverage(const Geometry *g, TextureView tv, HitL h, LF *alpha) {
    LI mi = FIELD_I(g->objects, hit_object(g, h), material);
    *alpha = 1.0f;
    WHERE(FIELD_I(tv.materials, mi, alpha_mode) != ALPHA_OPAQUE, *alpha, coverage_at(tv, mi, hit_data(g, h), h.u, h.v));
    return mi;
}

/* Whether hit h's point stops a ray, and in *opacity the share of the ray's light it stops, in the lanes `on` (a
 * mask: at width 1 set).  MASK: there (1) where alpha >= cutoff, else not (0).  BLEND: for the path tracer (rng not
 * null) there with probability alpha, the uniform number drawn only for BLEND (and only in the lanes `on`), so MASK
 * scenes use no random dimensions, *opacity left as it was; for the Whitted integrator (rng null) there with opacity
 * alpha when alpha > 0.  OPAQUE: there, 1. */
INLINE LI point_kept(const Geometry *g, TextureView tv, HitL h, Rng *rng, LI on, LF *opacity) {
    LF a;
    LI mi = hit_coverage(g, tv, h, &a);
    LI mode = FIELD_I(tv.materials, mi, alpha_mode);
    a = mode == ALPHA_MASK ? (a >= FIELD_F(tv.materials, mi, alpha_cutoff) ? (LF)(1.0f) : (LF)(0.0f)) : a;
    LI blend = on & (mode == ALPHA_BLEND) & (rng ? ALL_LANES : (LI)(0)), kept = a > 0.0f;
    if (ANY(blend)) kept = blend ? rng_extra(rng, blend) < a : kept;
    *opacity = blend ? *opacity : a;
    return kept;
}

#if LANES == 1
/* Fraction of light reaching t_max along the shadow ray r (Whitted): each point met in turn passes
 * (1 - opacity) + opacity x its material's transparency, through ALPHA_LAYERS points; the rest is
 * transmittance's (alpha ignored).  A walk of closest hits of one ray (no shafts, no packets). */
INLINE float alpha_transmittance(const Geometry *g, TextureView tv, Ray r, float t_max, uint *visits) {
    float T = 1.0f, t_min = 0.0f;
    for (int k = 0; k < ALPHA_LAYERS && T > 0.0f; ++k) {
        Hit h = closest_hit(g, r, t_min, t_max, visits);
        if (h.id < 0) return T;
        float opacity;
        point_kept(g, tv, h, 0, ALL_LANES, &opacity);
        T *= (1.0f - opacity) + opacity * tv.materials[g->objects[hit_object(g, h)].material].transparency;
        t_min = h.t; /* hits are in (t_min, t_max): this one is left out next */
    }
    return T > 0.0f ? T * transmittance(g, r, t_min, t_max, material_pass(tv.materials), visits) : 0.0f;
}
#endif
#endif

/* The first point along r in (t_min, t_max) that a ray stops at, for both integrators: closest_hit, looking past
 * alpha-rejected points (point_kept; rng and *opacity as there) and, for a camera ray, culled back faces, through
 * ALPHA_LAYERS of them; the next hit is kept whatever it is (opacity 1).  One closest_hit call site: each inlined
 * copy holds its own traversal stacks.  render_path_lanes looks past in lanes (path.cl seen_lanes): in its build this
 * is closest_hit. */
INLINE Hit seen_hit(const Geometry *g, TextureView tv, Ray r, float t_min, float t_max, bool camera, Rng *rng, float *opacity,
                    uint *visits) {
    *opacity = 1.0f;
#if LOOK_PAST && LANES == 1
    for (int k = 0;; ++k) {
        Hit h = closest_hit(g, r, t_min, t_max, visits);
        if (h.id < 0) return h;
        if (k == ALPHA_LAYERS) { *opacity = 1.0f; return h; }
        t_min = h.t; /* hits are in (t_min, t_max): a rejected one is left out next */
#if CULL_BACKFACES
        if (camera && back_culled(g, tv, h, r.o, r.d)) continue;
#endif
#if ALPHA_TEST
        if (point_kept(g, tv, h, rng, ALL_LANES, opacity)) return h;
#else
        return h;
#endif
    }
#else
    return closest_hit(g, r, t_min, t_max, visits);
#endif
}

#endif
