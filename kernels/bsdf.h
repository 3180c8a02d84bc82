/* BSDF lobes for the path tracer, and the one dispatch over them (OpenCL C 1.2, float32).  Include after common.h
 * and rng.h.  A material (kernels/material.h) is a set of these lobes; at a vertex it picks one, a Component (a
 * lobe code and its BsdfParams), and the integrator reaches it only through component_eval, component_pdf,
 * component_sample and component_is_delta at the end of this file (pbrt-v4's BxDF dispatch).  bsdf_probe.cl
 * runs the same four for the tests.
 *
 * Conventions, the same for every lobe:
 *   - Directions are unit vectors in the local shading frame, normal n = +z (make_frame, to_local,
 *     to_world), and both point AWAY from the surface: wo towards the viewer (the direction radiance
 *     leaves in), wi towards the light (the direction that is sampled).
 *   - *_eval(wo, wi) returns f(wo, wi) * |cos theta_i| (the BSDF times the cosine of wi: what a path's
 *     throughput is multiplied by per unit solid angle of wi), RGB.
 *   - *_pdf(wo, wi) is the solid-angle density of *_sample's wi.  Samples the sampler cannot produce
 *     (wi on the wrong side, a back-facing microfacet) are returned with weight 0 and pdf 0, so the pdf
 *     integrates to the fraction of valid samples: at most 1.
 *   - *_sample(wo, u1, u2) -> BsdfSample: wi, weight = eval / pdf (computed in a cancelled form where
 *     the division would lose precision), pdf.  u1 picks a lobe or between reflection and transmission;
 *     u2 places the direction.  Delta lobes (smooth dielectric) set `delta`: pdf is then the discrete
 *     probability of the branch taken, and eval / pdf of the lobe are 0.
 *   - Reflection-only lobes (Lambert, conductor, glTF) are one-sided: 0 unless wo.z > 0 and wi.z > 0.  The
 *     integrator puts the shading normal on wo's side for opaque surfaces.
 *   - Dielectrics: eta = (IOR on the -z side, "inside") / (IOR on the +z side, "outside"); wo may be on
 *     either side.  Transmission carries the radiance scaling: f_t includes (eta_o / eta_i)^2, with
 *     eta_o and eta_i the IORs on wo's and wi's sides, so f(wo, wi) eta_i^2 == f(wi, wo) eta_o^2
 *     (Veach 1997, 5.2; pbrt-v4's TransportMode::Radiance).  Importance transport would not scale.
 *   - GGX roughness is the Trowbridge-Reitz width `alpha` everywhere (isotropic).  glTF and Disney's
 *     perceptual roughness r maps to alpha = r^2: ggx_alpha_from_roughness.  alpha is clamped below at
 *     GGX_ALPHA_MIN: an exact mirror is a delta lobe, not a GGX one.
 *   - Masking-shadowing: every GGX lobe takes `smith` (SMITH_CORRELATED: the height-correlated G2 of glTF and
 *     pbrt, the default; SMITH_SEPARABLE: G1(wo) G1(wi), as Mitsuba's rough plugins).
 *
 *   - Lanes: every function here is written over kernels/lanes.h's lane type, for LANES paths a work-item (one at
 *     width 1, as path.cl builds it).  A lobe's conditions are masks, never branches on a lane: where the scalar code
 *     would return early, the lanes compute on and keep_sample (vpick, ?:) keeps the early answer, so each lane gets
 *     the bits the scalar code gives; `if (ANY(m))` runs a form (a lobe, the separable masking term, a sampling branch)
 *     only where some lane needs it, which at width 1 is the scalar branch itself.  Directions and colours are V3,
 *     a 2-D sample V2; delta and smith are lane ints (delta a mask).
 *
 * Lobe codes (BSDF_LAMBERT, ...) come from clrender/layout.py's BSDF_LOBES.  Adding a lobe: its code there, its
 * functions here, one line in each dispatch below (and component_is_delta for a delta lobe). */
#ifndef CLRENDER_BSDF_H
#define CLRENDER_BSDF_H

#include "mathf.h"
#include "lanes.h"
/* a * b + c fused here, as path.cl has always built these lobes (intersect.h, before them there, turns it on): the
 * probes and lane kernels that include this file compute the renderer's bits */
#pragma OPENCL FP_CONTRACT ON

#define GGX_ALPHA_MIN 1e-4f       /* smallest GGX alpha: D peaks at 1 / (pi alpha^2), 3.2e7, far from float overflow */
#define GLTF_DIELECTRIC_F0 0.04f  /* glTF 2.0 Appendix B: F0 of the dielectric layer, ((1 - ior) / (1 + ior))^2, ior 1.5 */
#define GLTF_LOBE_PROB_MIN 0.1f   /* glTF sampling: each lobe that can contribute is chosen at least this often */

/* A lobe's parameters. */
typedef struct {
    V3 colour;   /* Lambert: albedo; conductor: F0 (Schlick); glTF: base colour.  Linear RGB in [0, 1] */
    LF alpha;    /* GGX width of the conductor, rough dielectric and glTF lobes (not the perceptual roughness) */
    LF eta;      /* dielectrics: IOR inside (-z) / IOR outside (+z) */
    LF metallic; /* glTF: 0 dielectric ... 1 metal */
    LI smith;    /* SMITH_CORRELATED or SMITH_SEPARABLE: the GGX lobes' masking-shadowing term */
    /* the lobes of issue 36 (metal*, coated_diffuse*, thin_dielectric); colour is the coated diffuse's base */
    V3 eta3, k3;      /* metal: complex IOR eta + i k per channel */
    V3 tint;          /* specular reflectance: metal, coat, thin sheet; phong: ks, the glossy lobe's colour */
    V3 transmit_tint; /* specular transmittance: thin sheet, dielectrics (glTF glass: its base colour); else 1 */
    LI nonlinear;     /* coat: Mitsuba's nonlinear internal scattering (a mask) */
    LF coat_weight;   /* coat: specular sampling weight, mean(tint) / (mean(diffuse) + mean(tint)) */
    LF coat_internal; /* coat: internal diffuse reflectance */
    __global const float *coat_tables; /* rough coat: COAT_TABLE_RES values of the external transmittance ... */
    LI coat_table;                     /* ... at coat_tables + coat_table */
    LF specular_prob; /* phong: probability of sampling the glossy lobe rather than the Lambert one */
} BsdfParams;

typedef struct {
    V3 wi;     /* sampled direction (local frame, away from the surface) */
    V3 weight; /* eval / pdf: 0 for a failed sample */
    LF pdf;    /* solid-angle density; for a delta lobe, the probability of the branch taken */
    LI delta;  /* a mask: wi came from a delta lobe (no MIS with light sampling) */
    LF eta;    /* a refraction's relative IOR eta_i / eta_o, whose 1 / eta^2 the weight holds (pbrt-v4's); else 1 */
} BsdfSample;

INLINE BsdfSample no_sample(void) {
    BsdfSample s;
    s.wi = v3(0.0f, 0.0f, 1.0f);
    s.weight = v3_all(0.0f);
    s.pdf = 0.0f;
    s.delta = 0;
    s.eta = 1.0f;
    return s;
}

/* a non-delta sample */
INLINE BsdfSample sample_of(V3 wi, V3 weight, LF pdf) {
    BsdfSample s = no_sample();
    s.wi = wi;
    s.weight = weight;
    s.pdf = pdf;
    return s;
}

/* a in the lanes of m, b in the others */
INLINE BsdfSample keep_sample(LI m, BsdfSample a, BsdfSample b) {
    BsdfSample s;
    s.wi = vpick(m, a.wi, b.wi);
    s.weight = vpick(m, a.weight, b.weight);
    s.pdf = m ? a.pdf : b.pdf;
    s.delta = m ? a.delta : b.delta;
    s.eta = m ? a.eta : b.eta;
    return s;
}

/* ---- the local shading frame: an orthonormal basis (t, b, n), branchless (Duff et al. 2017) */
typedef struct {
    V3 t, b, n;
} Frame;

INLINE Frame make_frame(V3 n) {
    LF sign = n.z >= 0.0f ? (LF)(1.0f) : (LF)(-1.0f);
    LF a = -1.0f / (sign + n.z);
    LF c = n.x * n.y * a;
    Frame f;
    f.t = v3(1.0f + sign * n.x * n.x * a, sign * c, -sign * n.x);
    f.b = v3(c, sign + n.y * n.y * a, -n.y);
    f.n = n;
    return f;
}

INLINE V3 to_local(Frame f, V3 v) { return v3(vdot(v, f.t), vdot(v, f.b), vdot(v, f.n)); }
INLINE V3 to_world(Frame f, V3 v) {
    return v3(v.x * f.t.x + v.y * f.b.x + v.z * f.n.x, v.x * f.t.y + v.y * f.b.y + v.z * f.n.y, v.x * f.t.z + v.y * f.b.z + v.z * f.n.z);
}

/* ---- small helpers */
INLINE LF pow5(LF x) { return (x * x) * (x * x) * x; }
INLINE LF mean3(V3 c) { return (c.x + c.y + c.z) * (1.0f / 3.0f); }
INLINE LF sin2_of(V3 w) { return w.x * w.x + w.y * w.y; } /* sin^2 theta without 1 - cos^2 cancellation */
INLINE LF ggx_alpha_from_roughness(LF roughness) { return max_l(roughness * roughness, GGX_ALPHA_MIN); }
INLINE V3 mirror_about(V3 wo, V3 h) {
    LF k = 2.0f * vdot(wo, h);
    return v3(k * h.x - wo.x, k * h.y - wo.y, k * h.z - wo.z);
}
INLINE V3 mirror_z(V3 wo) { return v3(-wo.x, -wo.y, wo.z); } /* the mirror direction about the normal */

/* Schlick's Fresnel with an RGB F0: F = F0 + (1 - F0) (1 - cos)^5, cos = |wo . h|.  glTF's choice. */
INLINE V3 fresnel_schlick(V3 f0, LF cos_theta) {
    LF p = pow5(1.0f - abs_l(cos_theta));
    return v3(f0.x + (1.0f - f0.x) * p, f0.y + (1.0f - f0.y) * p, f0.z + (1.0f - f0.z) * p);
}

/* Exact unpolarised Fresnel reflectance of a smooth dielectric interface: the mean of the squared s- and
 * p-amplitude ratios.  cos_i = cos of the incident direction to the +z normal; cos_i < 0 means it arrives
 * from inside, where the relative index is 1 / eta.  Total internal reflection returns 1.  *cos_t gets the
 * (positive) cosine of the transmitted direction, 0 under TIR. */
INLINE LF fresnel_dielectric(LF cos_i, LF eta, LF *cos_t) {
    LI inside = cos_i < 0.0f;
    eta = inside ? 1.0f / eta : eta;
    cos_i = inside ? -cos_i : cos_i;
    LF cos2_t = (eta * eta - 1.0f + cos_i * cos_i) / (eta * eta); /* 1 - sin^2 theta_t, exact at eta = 1 */
    LI total_internal_reflection = cos2_t <= 0.0f;
    LF ct = sqrt_l(cos2_t);
    LF r_parallel = (eta * cos_i - ct) / (eta * cos_i + ct);
    LF r_perpendicular = (cos_i - eta * ct) / (cos_i + eta * ct);
    *cos_t = total_internal_reflection ? (LF)(0.0f) : ct;
    return total_internal_reflection ? (LF)(1.0f) : 0.5f * (r_parallel * r_parallel + r_perpendicular * r_perpendicular);
}

/* ---- Lambert: f = albedo / pi, cosine-weighted hemisphere sampling (pdf cos theta_i / pi) */
INLINE LI both_above(V3 wo, V3 wi) { return NOT((wo.z <= 0.0f) | (wi.z <= 0.0f)); }

INLINE V3 lambert_eval(V3 wo, V3 wi, V3 albedo) {
    return vpick((wo.z > 0.0f) & (wi.z > 0.0f), vscale(wi.z * M_1_PI_F, albedo), v3_all(0.0f));
}

INLINE LF lambert_pdf(V3 wo, V3 wi) { return ((wo.z > 0.0f) & (wi.z > 0.0f)) ? wi.z * M_1_PI_F : (LF)(0.0f); }

INLINE V3 cosine_hemisphere(V2 u) {
    LF r = sqrt_l(u.x), phi = 2.0f * M_PI_F * u.y, s, c;
    sincos_l(phi, &s, &c);
    return v3(r * c, r * s, sqrt_l(max_l(0.0f, 1.0f - u.x)));
}

INLINE BsdfSample lambert_sample(V3 wo, V2 u2, V3 albedo) {
    V3 wi = cosine_hemisphere(u2);
    /* weight (albedo / pi) cos / (cos / pi) */
    return keep_sample(both_above(wo, wi), sample_of(wi, albedo, wi.z * M_1_PI_F), no_sample());
}

/* ---- GGX (Trowbridge-Reitz), isotropic, width alpha.
 * D(h) = alpha^2 / (pi (cos^2 theta_h (alpha^2 - 1) + 1)^2), written as alpha^2 cos^2 + sin^2 so that small
 * alphas keep their precision.  Smith: Lambda(w) = (sqrt(1 + alpha^2 tan^2 theta) - 1) / 2, and with
 * R(w) = sqrt(cos^2 + alpha^2 sin^2):
 *   G1(w) = 1 / (1 + Lambda(w)) = 2 |cos| / (|cos| + R)
 *   G2(wo, wi) = 1 / (1 + Lambda(wo) + Lambda(wi)) = 2 |cos_o| |cos_i| / (R_o |cos_i| + R_i |cos_o|)
 * (height-correlated masking-shadowing, Heitz 2014), forms with no division by a cosine. */
INLINE LF ggx_d(V3 h, LF alpha) {
    LF a2 = alpha * alpha;
    LF den = a2 * h.z * h.z + sin2_of(h);
    LF d = a2 / (M_PI_F * den * den);
    return h.z <= 0.0f ? (LF)(0.0f) : d;
}

INLINE LF ggx_r(V3 w, LF alpha) { return sqrt_l(w.z * w.z + alpha * alpha * sin2_of(w)); }

INLINE LF ggx_g1(V3 w, LF alpha) {
    LF c = abs_l(w.z);
    return 2.0f * c / (c + ggx_r(w, alpha));
}

INLINE LF ggx_g2(V3 wo, V3 wi, LF alpha) {
    LF co = abs_l(wo.z), ci = abs_l(wi.z);
    LF den = ggx_r(wo, alpha) * ci + ggx_r(wi, alpha) * co;
    return den > 0.0f ? 2.0f * co * ci / den : (LF)(0.0f);
}

/* Mitsuba's separable masking-shadowing G1(wo) G1(wi) (its rough plugins' MicrofacetDistribution::G). */
INLINE LF ggx_g2_separable(V3 wo, V3 wi, LF alpha) { return ggx_g1(wo, alpha) * ggx_g1(wi, alpha); }

/* A GGX reflection's D G / (4 cos_o) (f cos_i with F = 1) and its sampling weight G / G1(wo) for a wi drawn from the
 * visible normals of wo, with either masking-shadowing term.  wo.z > 0, wi.z > 0, h = unit(wo + wi). */
INLINE LF ggx_reflection_value(V3 wo, V3 wi, V3 h, LF alpha, LI smith) {
    LI separable = smith == SMITH_SEPARABLE;
    LF v = 0.0f;
    WHERE(separable, v, ggx_d(h, alpha) * ggx_g2_separable(wo, wi, alpha) / (4.0f * wo.z));
    LF den = ggx_r(wo, alpha) * wi.z + ggx_r(wi, alpha) * wo.z;
    WHERE(NOT(separable), v, ggx_d(h, alpha) * wi.z / (2.0f * den));
    return v;
}

INLINE LF ggx_reflection_weight(V3 wo, V3 wi, LF alpha, LI smith) {
    LI separable = smith == SMITH_SEPARABLE;
    LF w = 0.0f;
    WHERE(separable, w, ggx_g1(wi, alpha));
    LF ro = ggx_r(wo, alpha), ri = ggx_r(wi, alpha);
    WHERE(NOT(separable), w, wi.z * (wo.z + ro) / (ro * wi.z + ri * wo.z));
    return w;
}

/* A microfacet normal from the distribution of normals visible from w (w.z > 0), D_w(h) =
 * G1(w) max(0, w . h) D(h) / w.z: Heitz 2018, "Sampling the GGX distribution of visible normals". */
INLINE V3 ggx_sample_vndf(V3 w, LF alpha, V2 u) {
    V3 wh = vunit(v3(alpha * w.x, alpha * w.y, w.z)); /* stretch to the hemisphere configuration */
    LF lensq = wh.x * wh.x + wh.y * wh.y;
    V3 t1 = vpick(lensq > 0.0f, vdiv(v3(-wh.y, wh.x, 0.0f), sqrt_l(lensq)), v3(1.0f, 0.0f, 0.0f));
    V3 t2 = vcross(wh, t1);
    LF r = sqrt_l(u.x), phi = 2.0f * M_PI_F * u.y, sin_phi, cos_phi; /* a point on the projected disk ... */
    sincos_l(phi, &sin_phi, &cos_phi);
    LF p1 = r * cos_phi, p2 = r * sin_phi;
    LF s = 0.5f * (1.0f + wh.z); /* ... warped to the visible half of it */
    p2 = (1.0f - s) * sqrt_l(max_l(0.0f, 1.0f - p1 * p1)) + s * p2;
    LF lift = sqrt_l(max_l(0.0f, 1.0f - p1 * p1 - p2 * p2)); /* onto the hemisphere */
    V3 nh = v3(p1 * t1.x + p2 * t2.x + lift * wh.x, p1 * t1.y + p2 * t2.y + lift * wh.y, p1 * t1.z + p2 * t2.z + lift * wh.z);
    return vunit(v3(alpha * nh.x, alpha * nh.y, max_l(0.0f, nh.z))); /* unstretch */
}

/* Density of a reflected wi sampled through ggx_sample_vndf(wo): D_wo(h) / (4 |wo . h|) = G1(wo) D(h) / (4 cos_o)
 * = D(h) / (2 (cos_o + R_o)).  wo.z > 0, h the half vector (h.z > 0). */
INLINE LF ggx_reflection_pdf(V3 wo, V3 h, LF alpha) { return ggx_d(h, alpha) / (2.0f * (abs_l(wo.z) + ggx_r(wo, alpha))); }

/* A direction from the visible normals of wo (wo.z > 0) mirrored about the normal: the GGX reflection lobes' sample;
 * *h gets the normal.  Valid where it and h are above the surface (the rest is the energy single scattering loses). */
INLINE V3 ggx_reflect_sample(V3 wo, LF alpha, V2 u2, V3 *h, LI *valid) {
    *h = ggx_sample_vndf(wo, alpha, u2);
    V3 wi = mirror_about(wo, *h);
    *valid = NOT((wo.z <= 0.0f) | (wi.z <= 0.0f) | (h->z <= 0.0f));
    return wi;
}

/* ---- GGX conductor: f = F D G2 / (4 cos_o cos_i), F Schlick's with an RGB F0 at |wo . h|.
 * eval = F D G2 / (4 cos_o) = F D cos_i / (2 (R_o cos_i + R_i cos_o)); weight = F G2 / G1(wo). */
INLINE V3 conductor_eval(V3 wo, V3 wi, V3 f0, LF alpha, LI smith) {
    alpha = max_l(alpha, GGX_ALPHA_MIN);
    V3 h = vunit(vadd(wo, wi));
    V3 f = vscale(ggx_reflection_value(wo, wi, h, alpha, smith), fresnel_schlick(f0, vdot(wo, h)));
    return vpick(both_above(wo, wi), f, v3_all(0.0f));
}

INLINE LF conductor_pdf(V3 wo, V3 wi, LF alpha) {
    LF pdf = ggx_reflection_pdf(wo, vunit(vadd(wo, wi)), max_l(alpha, GGX_ALPHA_MIN));
    return both_above(wo, wi) ? pdf : (LF)(0.0f);
}

INLINE BsdfSample conductor_sample(V3 wo, V2 u2, V3 f0, LF alpha, LI smith) {
    alpha = max_l(alpha, GGX_ALPHA_MIN);
    V3 h;
    LI valid;
    V3 wi = ggx_reflect_sample(wo, alpha, u2, &h, &valid);
    V3 weight = vscale(ggx_reflection_weight(wo, wi, alpha, smith), fresnel_schlick(f0, vdot(wo, h))); /* F G2 / G1(wo) */
    return keep_sample(valid, sample_of(wi, weight, ggx_reflection_pdf(wo, h, alpha)), no_sample());
}

/* ---- smooth dielectric: a delta reflection (probability F) and a delta refraction (probability 1 - F),
 * F the exact Fresnel reflectance at wo; weights 1 and (eta_o / eta_i)^2.  eval and pdf are 0. */
INLINE BsdfSample dielectric_sample(V3 wo, LF u1, LF eta) {
    LF cos_t;
    LF f = fresnel_dielectric(wo.z, eta, &cos_t);
    LI reflect = u1 < f, outside = wo.z > 0.0f;
    LF eta_rel = outside ? eta : 1.0f / eta; /* eta_i / eta_o: wi's side over wo's side */
    LF side = outside ? (LF)(1.0f) : (LF)(-1.0f);
    LF k = abs_l(wo.z) / eta_rel - cos_t;
    V3 refracted = vunit(v3(-wo.x / eta_rel + k * 0.0f, -wo.y / eta_rel + k * 0.0f, -wo.z / eta_rel + k * side));
    LF w = reflect ? (LF)(1.0f) : 1.0f / (eta_rel * eta_rel);
    BsdfSample s;
    s.wi = vpick(reflect, mirror_z(wo), refracted);
    s.weight = v3(w, w, w);
    s.pdf = reflect ? f : 1.0f - f;
    s.delta = ALL_LANES;
    s.eta = reflect ? (LF)(1.0f) : eta_rel;
    return keep_sample(wo.z != 0.0f, s, no_sample());
}

/* Shared by the rough dielectric's eval and pdf: the generalised half vector of (wo, wi) (Walter et al. 2007):
 * h = wo + wi for reflection, eta_o wo + eta_i wi for transmission, turned to +z; *len2 gets the squared length
 * of the unnormalised transmission vector (= (eta_i wi.h + eta_o wo.h)^2, the Jacobian's denominator).
 * False (0) where the pair cannot scatter: a grazing direction, eta = 1, a degenerate h, or a microfacet that
 * faces away from wo or wi. */
INLINE LI dielectric_half(V3 wo, V3 wi, LF eta, V3 *h, LF *eta_o, LF *eta_i, LF *len2) {
    LI index_matched = eta == 1.0f; /* a delta pass-through (rough_dielectric_sample): nothing to evaluate */
    LI reflect = wo.z * wi.z > 0.0f;
    *eta_o = wo.z > 0.0f ? (LF)(1.0f) : eta;
    *eta_i = wi.z > 0.0f ? (LF)(1.0f) : eta;
    LF a = *eta_o, b = *eta_i;
    V3 v = vpick(reflect, vadd(wo, wi), v3(a * wo.x + b * wi.x, a * wo.y + b * wi.y, a * wo.z + b * wi.z));
    *len2 = vdot(v, v);
    v = vdiv(v, sqrt_l(*len2));
    *h = vpick(v.z < 0.0f, vneg(v), v);
    LI facing = (vdot(wo, *h) * wo.z > 0.0f) & (vdot(wi, *h) * wi.z > 0.0f);
    return NOT((wo.z == 0.0f) | (wi.z == 0.0f) | index_matched) & (*len2 > 0.0f) & facing;
}

/* The direction whose cosine to h Fresnel takes: wo, except for a transmission out of the denser side, where wi
 * (on the less dense side) is used.  Across the interface both give the same F, but near the critical angle
 * 1 - F computed from the denser side amplifies that cosine's rounding a thousandfold; from the other side it is
 * linear in a cosine near 0. */
INLINE V3 fresnel_side(V3 wo, V3 wi, LF eta) {
    LI transmission = wo.z * wi.z < 0.0f;
    LI wo_denser = (wo.z < 0.0f) == (eta > 1.0f);
    return vpick(transmission & wo_denser, wi, wo);
}

/* ---- rough dielectric (Walter et al. 2007), GGX, exact Fresnel F at wo . h (fresnel_side):
 *   reflection:   f = F D G2 / (4 |cos_o| |cos_i|)
 *   transmission: f = (1 - F) D G2 |wi.h| |wo.h| eta_o^2 / (|cos_o| |cos_i| (eta_i wi.h + eta_o wo.h)^2)
 * (the radiance form: eta_o^2 in the numerator).  Sampling: h from the visible normals of wo (flipped to +z),
 * reflect with probability F, else refract.  eta = 1 is sampled as the smooth lobe (straight through, delta). */
INLINE V3 rough_dielectric_eval(V3 wo, V3 wi, LF eta, LF alpha, LI smith) {
    V3 h;
    LF eta_o, eta_i, len2, cos_t;
    LI valid = dielectric_half(wo, wi, eta, &h, &eta_o, &eta_i, &len2);
    if (!ANY(valid)) return v3_all(0.0f);
    alpha = max_l(alpha, GGX_ALPHA_MIN);
    LF co = abs_l(wo.z), ci = abs_l(wi.z);
    LI separable = smith == SMITH_SEPARABLE;
    LF d_g2_over_co = 0.0f; /* D G2 / cos_o */
    WHERE(NOT(separable), d_g2_over_co, ggx_d(h, alpha) * 2.0f * ci / (ggx_r(wo, alpha) * ci + ggx_r(wi, alpha) * co));
    WHERE(separable, d_g2_over_co, ggx_d(h, alpha) * ggx_g2_separable(wo, wi, alpha) / co);
    LF f = fresnel_dielectric(vdot(fresnel_side(wo, wi, eta), h), eta, &cos_t);
    LF jacobian = abs_l(vdot(wi, h)) * abs_l(vdot(wo, h)) * eta_o * eta_o / len2;
    LF v = wo.z * wi.z > 0.0f ? f * d_g2_over_co * 0.25f : (1.0f - f) * d_g2_over_co * jacobian;
    v = valid ? v : (LF)(0.0f);
    return v3(v, v, v);
}

INLINE LF rough_dielectric_pdf(V3 wo, V3 wi, LF eta, LF alpha) {
    V3 h;
    LF eta_o, eta_i, len2, cos_t;
    LI valid = dielectric_half(wo, wi, eta, &h, &eta_o, &eta_i, &len2);
    if (!ANY(valid)) return 0.0f;
    alpha = max_l(alpha, GGX_ALPHA_MIN);
    LF f = fresnel_dielectric(vdot(fresnel_side(wo, wi, eta), h), eta, &cos_t);
    LF visible = ggx_d(h, alpha) / (abs_l(wo.z) + ggx_r(wo, alpha)); /* D_wo(h) / (2 |wo . h|) */
    LF dh_dwi = eta_i * eta_i * abs_l(vdot(wi, h)) / len2;           /* Walter's eq. 17 */
    /* reflection: D_wo(h) / (4 |wo . h|) */
    LF pdf = wo.z * wi.z > 0.0f ? f * visible * 0.5f : (1.0f - f) * visible * 2.0f * abs_l(vdot(wo, h)) * dh_dwi;
    return valid ? pdf : (LF)(0.0f);
}

INLINE BsdfSample rough_dielectric_sample(V3 wo, LF u1, V2 u2, LF eta, LF alpha, LI smith) {
    LI index_matched = eta == 1.0f; /* no interface: light passes straight through, a delta (h is undefined) */
    alpha = max_l(alpha, GGX_ALPHA_MIN);
    LF side = wo.z > 0.0f ? (LF)(1.0f) : (LF)(-1.0f);
    V3 h = ggx_sample_vndf(vscale(side, wo), alpha, u2);
    LF cos_oh = vdot(wo, h); /* same sign as wo.z */
    LF cos_t;
    LF f = fresnel_dielectric(cos_oh, eta, &cos_t);
    LI reflect = u1 < f; /* always under total internal reflection (f = 1) */
    LF eta_rel = reflect ? (LF)(1.0f) : (side > 0.0f ? eta : 1.0f / eta); /* eta_i / eta_o */
    V3 h_o = vscale(side, h);                                              /* h on wo's side */
    LF k = abs_l(cos_oh) / eta_rel - cos_t;
    V3 refracted = vunit(v3(-wo.x / eta_rel + k * h_o.x, -wo.y / eta_rel + k * h_o.y, -wo.z / eta_rel + k * h_o.z));
    V3 wi = vpick(reflect, mirror_about(wo, h), refracted);
    LI on_its_side = reflect ? (wi.z * side > 0.0f) : (wi.z * side < 0.0f);
    LF co = abs_l(wo.z), ci = abs_l(wi.z), ro = ggx_r(wo, alpha);
    LI separable = smith == SMITH_SEPARABLE;
    LF w = 0.0f; /* G2 / G1(wo) / eta^2 */
    WHERE(NOT(separable), w, ci * (co + ro) / (ro * ci + ggx_r(wi, alpha) * co) / (eta_rel * eta_rel));
    WHERE(separable, w, ggx_g1(wi, alpha) / (eta_rel * eta_rel));
    BsdfSample s = sample_of(wi, v3(w, w, w), rough_dielectric_pdf(wo, wi, eta, alpha)); /* from wi, as MIS will see it */
    s.eta = eta_rel;
    LI valid = NOT((wo.z == 0.0f) | (h.z <= 0.0f) | (cos_oh * side <= 0.0f)) & on_its_side & (s.pdf > 0.0f);
    s = keep_sample(valid, s, no_sample());
    if (ANY(index_matched)) s = keep_sample(index_matched, dielectric_sample(wo, u1, eta), s);
    return s;
}

/* ---- glTF 2.0 metallic-roughness, Appendix B of the specification:
 *   material        = mix(dielectric_brdf, metal_brdf, metallic)
 *   metal_brdf      = conductor_fresnel(f0 = base, specular_brdf)      -> F_m specular, F_m = Schlick(base)
 *   dielectric_brdf = fresnel_mix(ior 1.5, diffuse_brdf, specular_brdf) -> (1 - F_d) base / pi + F_d specular,
 *                     F_d = Schlick(0.04) (a scalar)
 *   specular_brdf   = D G2 / (4 cos_o cos_i), the GGX lobe above with alpha = roughness^2 (the caller converts)
 * with every Fresnel at |wo . h|, h = unit(wo + wi).  This is the specification's exact mix, not its
 * "implementation" shortcut, which weights the diffuse by (1 - F) of the mixed F0 and differs for
 * 0 < metallic < 1.
 * Sampling: the specular lobe (visible normals) with probability p_spec, else the cosine-weighted diffuse;
 * p_spec = E_s / (E_s + E_d) from Schlick at cos_o: E_s = (1 - m) F_d(cos_o) + m mean(F_m(cos_o)),
 * E_d = (1 - m) (1 - F_d(cos_o)) mean(base), kept within [GLTF_LOBE_PROB_MIN, 1 - GLTF_LOBE_PROB_MIN]
 * while E_d > 0 (1 when the diffuse lobe is black).  pdf = the mixture p_spec pdf_spec + (1 - p_spec) pdf_diffuse,
 * and a sample's weight is the whole BRDF over that mixture pdf. */
INLINE LF gltf_specular_probability(V3 wo, V3 base, LF metallic) {
    LF s = pow5(1.0f - wo.z);
    LF f_d = GLTF_DIELECTRIC_F0 + (1.0f - GLTF_DIELECTRIC_F0) * s;
    LF e_s = (1.0f - metallic) * f_d + metallic * mean3(fresnel_schlick(base, wo.z));
    LF e_d = (1.0f - metallic) * (1.0f - f_d) * mean3(base);
    LF p = clamp_l(e_s / (e_s + e_d), GLTF_LOBE_PROB_MIN, 1.0f - GLTF_LOBE_PROB_MIN);
    return e_d > 0.0f ? p : (LF)(1.0f);
}

INLINE V3 gltf_eval(V3 wo, V3 wi, V3 base, LF metallic, LF alpha, LI smith) {
    alpha = max_l(alpha, GGX_ALPHA_MIN);
    V3 h = vunit(vadd(wo, wi));
    LF c = vdot(wo, h);
    LF specular = ggx_reflection_value(wo, wi, h, alpha, smith); /* D G2 / (4 cos_o) */
    LF f_d = GLTF_DIELECTRIC_F0 + (1.0f - GLTF_DIELECTRIC_F0) * pow5(1.0f - c);
    LF k = wi.z * M_1_PI_F, fs = f_d * specular, m = metallic;
    V3 dielectric = v3((1.0f - f_d) * base.x * k + fs, (1.0f - f_d) * base.y * k + fs, (1.0f - f_d) * base.z * k + fs);
    V3 metal = vscale(specular, fresnel_schlick(base, c));
    V3 f = v3((1.0f - m) * dielectric.x + m * metal.x, (1.0f - m) * dielectric.y + m * metal.y, (1.0f - m) * dielectric.z + m * metal.z);
    return vpick(both_above(wo, wi), f, v3_all(0.0f));
}

INLINE LF gltf_pdf(V3 wo, V3 wi, V3 base, LF metallic, LF alpha) {
    LF p_spec = gltf_specular_probability(wo, base, metallic);
    LF pdf = p_spec * conductor_pdf(wo, wi, alpha) + (1.0f - p_spec) * lambert_pdf(wo, wi);
    return both_above(wo, wi) ? pdf : (LF)(0.0f);
}

/* A direction of a mixture of the GGX reflection (probability p_spec) and the cosine-weighted diffuse lobe */
INLINE V3 glossy_or_diffuse(V3 wo, LI glossy, LF alpha, V2 u2) {
    V3 wi = v3_all(0.0f);
    WHERE3(glossy, wi, mirror_about(wo, ggx_sample_vndf(wo, alpha, u2)));
    WHERE3(NOT(glossy), wi, cosine_hemisphere(u2));
    return wi;
}

INLINE BsdfSample gltf_sample(V3 wo, LF u1, V2 u2, V3 base, LF metallic, LF alpha, LI smith) {
    LF p_spec = gltf_specular_probability(wo, base, metallic);
    V3 wi = glossy_or_diffuse(wo, u1 < p_spec, max_l(alpha, GGX_ALPHA_MIN), u2);
    LF pdf = gltf_pdf(wo, wi, base, metallic, alpha);
    BsdfSample s = sample_of(wi, vdiv(gltf_eval(wo, wi, base, metallic, alpha, smith), pdf), pdf);
    return keep_sample(both_above(wo, wi) & (pdf > 0.0f), s, no_sample());
}

/* ---- mirror: a perfect mirror of reflectance `colour` (the Phong material's mirror share; a delta: eval and pdf 0) */
INLINE BsdfSample delta_reflection(V3 wo, V3 weight, LF pdf) {
    BsdfSample s = sample_of(mirror_z(wo), weight, pdf);
    s.delta = ALL_LANES;
    return s;
}

INLINE BsdfSample mirror_sample(V3 wo, V3 colour) { return keep_sample(NOT(wo.z <= 0.0f), delta_reflection(wo, colour, 1.0f), no_sample()); }

/* ---- phong: the Phong material's Lambert-plus-glossy mix, f cos = Lambert(colour = kd) + ks x the GGX conductor with
 * F = 1 (tint = ks, alpha its width, SMITH_CORRELATED), kd + ks <= 1 per channel (material.h scales them).
 * Sampling: the glossy lobe (visible normals) with probability specular_prob, else the cosine-weighted Lambert;
 * pdf the mixture, a sample's weight the sum's value over that mixture pdf. */
INLINE V3 phong_eval(V3 wo, V3 wi, BsdfParams p) {
    V3 f = lambert_eval(wo, wi, p.colour);
    V3 g = conductor_eval(wo, wi, v3_all(1.0f), p.alpha, SMITH_CORRELATED);
    return v3(f.x + p.tint.x * g.x, f.y + p.tint.y * g.y, f.z + p.tint.z * g.z);
}

INLINE LF phong_pdf(V3 wo, V3 wi, BsdfParams p) {
    LF pdf = lambert_pdf(wo, wi);
    pdf = (1.0f - p.specular_prob) * pdf + p.specular_prob * conductor_pdf(wo, wi, p.alpha);
    return pdf;
}

INLINE BsdfSample phong_sample(V3 wo, LF u1, V2 u2, BsdfParams p) {
    LI glossy = u1 < p.specular_prob;
    BsdfSample s = no_sample();
    if (ANY(glossy)) s = keep_sample(glossy, conductor_sample(wo, u2, v3_all(1.0f), p.alpha, SMITH_CORRELATED), s);
    if (ANY(NOT(glossy))) s = keep_sample(NOT(glossy), lambert_sample(wo, u2, p.colour), s);
    LI valid = s.pdf > 0.0f;
    s.pdf = phong_pdf(wo, s.wi, p);
    s.weight = vdiv(phong_eval(wo, s.wi, p), s.pdf);
    return keep_sample(valid & (s.pdf > 0.0f), s, no_sample());
}

/* The dielectrics' specular transmittance (Mitsuba's specular_transmittance; glTF glass's base colour, which
 * KHR_materials_transmission puts on the BTDF only): a value or weight times transmit_tint for a pair of
 * directions through the surface, untouched on reflection. */
INLINE V3 transmission_tinted(V3 v, V3 wo, V3 wi, BsdfParams p) { return vpick(wo.z * wi.z < 0.0f, vmul(v, p.transmit_tint), v); }

/* the lobes Mitsuba and pbrt scenes need: metal, coated diffuse, thin dielectric */
#include "bsdf_exchange.h"

/* ---------------------------------------------------------------- the dispatch
 * The lobe a material picked at a vertex, with its parameters: what the integrator samples and evaluates.  In lanes,
 * one masked pass per lobe that some lane has (FOR_LOBE); at width 1, the branch of the one lobe present. */
typedef struct {
    LI lobe; /* a BSDF_* code */
    BsdfParams bsdf;
} Component;

#define FOR_LOBE(code, x, keep, value) if (ANY(lobe == (code))) x = keep(lobe == (code), (value), x)
INLINE LF pick_l(LI m, LF a, LF b) { return m ? a : b; }

/* a in the lanes of m, b in the others (the table pointer is the same in every lane) */
INLINE Component keep_component(LI m, Component a, Component b) {
    Component c = a;
    c.lobe = m ? a.lobe : b.lobe;
#define KEEP3(f) c.bsdf.f = vpick(m, a.bsdf.f, b.bsdf.f)
#define KEEP(f) c.bsdf.f = m ? a.bsdf.f : b.bsdf.f
    KEEP3(colour); KEEP(alpha); KEEP(eta); KEEP(metallic); KEEP(smith); KEEP3(eta3); KEEP3(k3); KEEP3(tint);
    KEEP3(transmit_tint); KEEP(nonlinear); KEEP(coat_weight); KEEP(coat_internal); KEEP(coat_table); KEEP(specular_prob);
#undef KEEP
#undef KEEP3
    return c;
}

/* Delta lobes: eval and pdf are 0, their samples carry `delta`, and light sampling cannot reach them (no NEE). */
INLINE LI component_is_delta(Component c) {
    return (c.lobe == BSDF_MIRROR) | (c.lobe == BSDF_DIELECTRIC) | (c.lobe == BSDF_METAL_SMOOTH) | (c.lobe == BSDF_THIN_DIELECTRIC);
}

/* The lobes whose eta is inside over outside: their frame's +z must point out of the object (material.h). */
INLINE LI component_is_dielectric(Component c) { return (c.lobe == BSDF_DIELECTRIC) | (c.lobe == BSDF_ROUGH_DIELECTRIC); }

/* f * |cos theta_i| of the component, local frame (delta lobes: 0). */
INLINE V3 component_eval(Component c, V3 wo, V3 wi) {
    LI lobe = c.lobe;
    BsdfParams p = c.bsdf;
    V3 f = v3_all(0.0f); /* the delta lobes */
    FOR_LOBE(BSDF_LAMBERT, f, vpick, lambert_eval(wo, wi, p.colour));
    FOR_LOBE(BSDF_PHONG, f, vpick, phong_eval(wo, wi, p));
    FOR_LOBE(BSDF_CONDUCTOR, f, vpick, conductor_eval(wo, wi, p.colour, p.alpha, p.smith));
    FOR_LOBE(BSDF_ROUGH_DIELECTRIC, f, vpick, transmission_tinted(rough_dielectric_eval(wo, wi, p.eta, p.alpha, p.smith), wo, wi, p));
    FOR_LOBE(BSDF_GLTF, f, vpick, gltf_eval(wo, wi, p.colour, p.metallic, p.alpha, p.smith));
    FOR_LOBE(BSDF_METAL, f, vpick, metal_eval(wo, wi, p));
    FOR_LOBE(BSDF_COATED_DIFFUSE, f, vpick, coated_eval(wo, wi, p));
    FOR_LOBE(BSDF_COATED_DIFFUSE_SMOOTH, f, vpick, coated_smooth_eval(wo, wi, p));
    return f;
}

/* The solid-angle density of component_sample's wi (delta lobes: 0). */
INLINE LF component_pdf(Component c, V3 wo, V3 wi) {
    LI lobe = c.lobe;
    BsdfParams p = c.bsdf;
    LF pdf = 0.0f;
    FOR_LOBE(BSDF_LAMBERT, pdf, pick_l, lambert_pdf(wo, wi));
    FOR_LOBE(BSDF_PHONG, pdf, pick_l, phong_pdf(wo, wi, p));
    FOR_LOBE(BSDF_CONDUCTOR, pdf, pick_l, conductor_pdf(wo, wi, p.alpha));
    FOR_LOBE(BSDF_ROUGH_DIELECTRIC, pdf, pick_l, rough_dielectric_pdf(wo, wi, p.eta, p.alpha));
    FOR_LOBE(BSDF_GLTF, pdf, pick_l, gltf_pdf(wo, wi, p.colour, p.metallic, p.alpha));
    FOR_LOBE(BSDF_METAL, pdf, pick_l, conductor_pdf(wo, wi, p.alpha));
    FOR_LOBE(BSDF_COATED_DIFFUSE, pdf, pick_l, coated_pdf(wo, wi, p));
    FOR_LOBE(BSDF_COATED_DIFFUSE_SMOOTH, pdf, pick_l, coated_smooth_pdf(wo, wi, p));
    return pdf;
}

/* One direction wi from the component: u1 picks a sub-lobe or reflection vs transmission, u2 places wi. */
INLINE BsdfSample component_sample(Component c, V3 wo, LF u1, V2 u2) {
    LI lobe = c.lobe;
    BsdfParams p = c.bsdf;
    BsdfSample s = no_sample();
    FOR_LOBE(BSDF_LAMBERT, s, keep_sample, lambert_sample(wo, u2, p.colour));
    FOR_LOBE(BSDF_PHONG, s, keep_sample, phong_sample(wo, u1, u2, p));
    FOR_LOBE(BSDF_MIRROR, s, keep_sample, mirror_sample(wo, p.colour));
    FOR_LOBE(BSDF_CONDUCTOR, s, keep_sample, conductor_sample(wo, u2, p.colour, p.alpha, p.smith));
    FOR_LOBE(BSDF_DIELECTRIC, s, keep_sample, dielectric_sample(wo, u1, p.eta));
    FOR_LOBE(BSDF_ROUGH_DIELECTRIC, s, keep_sample, rough_dielectric_sample(wo, u1, u2, p.eta, p.alpha, p.smith));
    LI dielectric = component_is_dielectric(c);
    WHERE3(dielectric, s.weight, transmission_tinted(s.weight, wo, s.wi, p));
    FOR_LOBE(BSDF_GLTF, s, keep_sample, gltf_sample(wo, u1, u2, p.colour, p.metallic, p.alpha, p.smith));
    FOR_LOBE(BSDF_METAL, s, keep_sample, metal_sample(wo, u2, p));
    FOR_LOBE(BSDF_METAL_SMOOTH, s, keep_sample, metal_smooth_sample(wo, p));
    FOR_LOBE(BSDF_COATED_DIFFUSE, s, keep_sample, coated_sample(wo, u1, u2, p));
    FOR_LOBE(BSDF_COATED_DIFFUSE_SMOOTH, s, keep_sample, coated_smooth_sample(wo, u1, u2, p));
    FOR_LOBE(BSDF_THIN_DIELECTRIC, s, keep_sample, thin_dielectric_sample(wo, u1, p));
    return s;
}

#endif
