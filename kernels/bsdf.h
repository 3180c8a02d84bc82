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
 * Lobe codes (BSDF_LAMBERT, ...) come from clrender/layout.py's BSDF_LOBES.  Adding a lobe: its code there, its
 * functions here, one line in each dispatch below (and component_is_delta for a delta lobe). */
#ifndef CLRENDER_BSDF_H
#define CLRENDER_BSDF_H

#include "mathf.h"


#define GGX_ALPHA_MIN 1e-4f       /* smallest GGX alpha: D peaks at 1 / (pi alpha^2), 3.2e7, far from float overflow */
#define GLTF_DIELECTRIC_F0 0.04f  /* glTF 2.0 Appendix B: F0 of the dielectric layer, ((1 - ior) / (1 + ior))^2, ior 1.5 */
#define GLTF_LOBE_PROB_MIN 0.1f   /* glTF sampling: each lobe that can contribute is chosen at least this often */

/* A lobe's parameters. */
typedef struct {
    float3 colour;  /* Lambert: albedo; conductor: F0 (Schlick); glTF: base colour.  Linear RGB in [0, 1] */
    float alpha;    /* GGX width of the conductor, rough dielectric and glTF lobes (not the perceptual roughness) */
    float eta;      /* dielectrics: IOR inside (-z) / IOR outside (+z) */
    float metallic; /* glTF: 0 dielectric ... 1 metal */
    int smith;      /* SMITH_CORRELATED or SMITH_SEPARABLE: the GGX lobes' masking-shadowing term */
    /* the lobes of issue 36 (metal*, coated_diffuse*, thin_dielectric); colour is the coated diffuse's base */
    float3 eta3, k3;      /* metal: complex IOR eta + i k per channel */
    float3 tint;          /* specular reflectance: metal, coat, thin sheet; phong: ks, the glossy lobe's colour */
    float3 transmit_tint; /* specular transmittance: thin sheet, dielectrics (glTF glass: its base colour); else 1 */
    int nonlinear;        /* coat: Mitsuba's nonlinear internal scattering */
    float coat_weight;    /* coat: specular sampling weight, mean(tint) / (mean(diffuse) + mean(tint)) */
    float coat_internal;  /* coat: internal diffuse reflectance */
    __global const float *coat_transmittance; /* rough coat: COAT_TABLE_RES values of the external transmittance */
    float specular_prob;  /* phong: probability of sampling the glossy lobe rather than the Lambert one */
} BsdfParams;

typedef struct {
    float3 wi;     /* sampled direction (local frame, away from the surface) */
    float3 weight; /* eval / pdf: 0 for a failed sample */
    float pdf;     /* solid-angle density; for a delta lobe, the probability of the branch taken */
    int delta;     /* 1: wi came from a delta lobe (no MIS with light sampling) */
    float eta;     /* a refraction's relative IOR eta_i / eta_o, whose 1 / eta^2 the weight holds (pbrt-v4's); else 1 */
} BsdfSample;

INLINE BsdfSample no_sample(void) {
    BsdfSample s;
    s.wi = (float3)(0.0f, 0.0f, 1.0f);
    s.weight = (float3)(0.0f);
    s.pdf = 0.0f;
    s.delta = 0;
    s.eta = 1.0f;
    return s;
}

/* ---- the local shading frame: an orthonormal basis (t, b, n), branchless (Duff et al. 2017) */
typedef struct {
    float3 t, b, n;
} Frame;

INLINE Frame make_frame(float3 n) {
    float sign = n.z >= 0.0f ? 1.0f : -1.0f;
    float a = -1.0f / (sign + n.z);
    float c = n.x * n.y * a;
    Frame f;
    f.t = (float3)(1.0f + sign * n.x * n.x * a, sign * c, -sign * n.x);
    f.b = (float3)(c, sign + n.y * n.y * a, -n.y);
    f.n = n;
    return f;
}

INLINE float3 to_local(Frame f, float3 v) { return (float3)(dot3(v, f.t), dot3(v, f.b), dot3(v, f.n)); }
INLINE float3 to_world(Frame f, float3 v) { return v.x * f.t + v.y * f.b + v.z * f.n; }

/* ---- small helpers */
INLINE float pow5(float x) { return (x * x) * (x * x) * x; }
INLINE float sqr(float x) { return x * x; }
INLINE float mean3(float3 c) { return (c.x + c.y + c.z) * (1.0f / 3.0f); }
INLINE float sin2_of(float3 w) { return w.x * w.x + w.y * w.y; } /* sin^2 theta without 1 - cos^2 cancellation */
INLINE float ggx_alpha_from_roughness(float roughness) { return max_f(roughness * roughness, GGX_ALPHA_MIN); }
INLINE float3 mirror_about(float3 wo, float3 h) { return 2.0f * dot3(wo, h) * h - wo; }

/* Schlick's Fresnel with an RGB F0: F = F0 + (1 - F0) (1 - cos)^5, cos = |wo . h|.  glTF's choice. */
INLINE float3 fresnel_schlick(float3 f0, float cos_theta) { return f0 + ((float3)(1.0f) - f0) * pow5(1.0f - abs_f(cos_theta)); }

/* Exact unpolarised Fresnel reflectance of a smooth dielectric interface: the mean of the squared s- and
 * p-amplitude ratios.  cos_i = cos of the incident direction to the +z normal; cos_i < 0 means it arrives
 * from inside, where the relative index is 1 / eta.  Total internal reflection returns 1.  *cos_t gets the
 * (positive) cosine of the transmitted direction, 0 under TIR. */
INLINE float fresnel_dielectric(float cos_i, float eta, float *cos_t) {
    if (cos_i < 0.0f) {
        eta = 1.0f / eta;
        cos_i = -cos_i;
    }
    float cos2_t = (eta * eta - 1.0f + cos_i * cos_i) / (eta * eta); /* 1 - sin^2 theta_t, exact at eta = 1 */
    bool total_internal_reflection = cos2_t <= 0.0f;
    if (total_internal_reflection) {
        *cos_t = 0.0f;
        return 1.0f;
    }
    float ct = SQRT(cos2_t);
    float r_parallel = (eta * cos_i - ct) / (eta * cos_i + ct);
    float r_perpendicular = (cos_i - eta * ct) / (cos_i + eta * ct);
    *cos_t = ct;
    return 0.5f * (r_parallel * r_parallel + r_perpendicular * r_perpendicular);
}

/* ---- Lambert: f = albedo / pi, cosine-weighted hemisphere sampling (pdf cos theta_i / pi) */
INLINE float3 lambert_eval(float3 wo, float3 wi, float3 albedo) {
    bool both_above = wo.z > 0.0f && wi.z > 0.0f;
    return both_above ? albedo * (wi.z * M_1_PI_F) : (float3)(0.0f);
}

INLINE float lambert_pdf(float3 wo, float3 wi) { return (wo.z > 0.0f && wi.z > 0.0f) ? wi.z * M_1_PI_F : 0.0f; }

INLINE float3 cosine_hemisphere(float2 u) {
    float r = SQRT(u.x), phi = 2.0f * M_PI_F * u.y, s, c;
    SINCOS(phi, s, c);
    return (float3)(r * c, r * s, SQRT(max_f(0.0f, 1.0f - u.x)));
}

INLINE BsdfSample lambert_sample(float3 wo, float2 u2, float3 albedo) {
    BsdfSample s = no_sample();
    float3 wi = cosine_hemisphere(u2);
    if (wo.z <= 0.0f || wi.z <= 0.0f) return s;
    s.wi = wi;
    s.pdf = wi.z * M_1_PI_F;
    s.weight = albedo; /* (albedo / pi) cos / (cos / pi) */
    return s;
}

/* ---- GGX (Trowbridge-Reitz), isotropic, width alpha.
 * D(h) = alpha^2 / (pi (cos^2 theta_h (alpha^2 - 1) + 1)^2), written as alpha^2 cos^2 + sin^2 so that small
 * alphas keep their precision.  Smith: Lambda(w) = (sqrt(1 + alpha^2 tan^2 theta) - 1) / 2, and with
 * R(w) = sqrt(cos^2 + alpha^2 sin^2):
 *   G1(w) = 1 / (1 + Lambda(w)) = 2 |cos| / (|cos| + R)
 *   G2(wo, wi) = 1 / (1 + Lambda(wo) + Lambda(wi)) = 2 |cos_o| |cos_i| / (R_o |cos_i| + R_i |cos_o|)
 * (height-correlated masking-shadowing, Heitz 2014), forms with no division by a cosine. */
INLINE float ggx_d(float3 h, float alpha) {
    if (h.z <= 0.0f) return 0.0f;
    float a2 = alpha * alpha;
    float den = a2 * h.z * h.z + sin2_of(h);
    return a2 / (M_PI_F * den * den);
}

INLINE float ggx_r(float3 w, float alpha) { return SQRT(w.z * w.z + alpha * alpha * sin2_of(w)); }

INLINE float ggx_g1(float3 w, float alpha) {
    float c = abs_f(w.z);
    return 2.0f * c / (c + ggx_r(w, alpha));
}

INLINE float ggx_g2(float3 wo, float3 wi, float alpha) {
    float co = abs_f(wo.z), ci = abs_f(wi.z);
    float den = ggx_r(wo, alpha) * ci + ggx_r(wi, alpha) * co;
    return den > 0.0f ? 2.0f * co * ci / den : 0.0f;
}

/* Mitsuba's separable masking-shadowing G1(wo) G1(wi) (its rough plugins' MicrofacetDistribution::G). */
INLINE float ggx_g2_separable(float3 wo, float3 wi, float alpha) { return ggx_g1(wo, alpha) * ggx_g1(wi, alpha); }

/* A GGX reflection's D G / (4 cos_o) (f cos_i with F = 1) and its sampling weight G / G1(wo) for a wi drawn from the
 * visible normals of wo, with either masking-shadowing term.  wo.z > 0, wi.z > 0, h = unit(wo + wi). */
INLINE float ggx_reflection_value(float3 wo, float3 wi, float3 h, float alpha, int smith) {
    if (smith == SMITH_SEPARABLE) return ggx_d(h, alpha) * ggx_g2_separable(wo, wi, alpha) / (4.0f * wo.z);
    float den = ggx_r(wo, alpha) * wi.z + ggx_r(wi, alpha) * wo.z;
    return ggx_d(h, alpha) * wi.z / (2.0f * den);
}

INLINE float ggx_reflection_weight(float3 wo, float3 wi, float alpha, int smith) {
    if (smith == SMITH_SEPARABLE) return ggx_g1(wi, alpha);
    float ro = ggx_r(wo, alpha), ri = ggx_r(wi, alpha);
    return wi.z * (wo.z + ro) / (ro * wi.z + ri * wo.z);
}

/* A microfacet normal from the distribution of normals visible from w (w.z > 0), D_w(h) =
 * G1(w) max(0, w . h) D(h) / w.z: Heitz 2018, "Sampling the GGX distribution of visible normals". */
INLINE float3 ggx_sample_vndf(float3 w, float alpha, float2 u) {
    float3 wh = unit((float3)(alpha * w.x, alpha * w.y, w.z)); /* stretch to the hemisphere configuration */
    float lensq = wh.x * wh.x + wh.y * wh.y;
    float3 t1 = lensq > 0.0f ? (float3)(-wh.y, wh.x, 0.0f) / SQRT(lensq) : (float3)(1.0f, 0.0f, 0.0f);
    float3 t2 = cross3(wh, t1);
    float r = SQRT(u.x), phi = 2.0f * M_PI_F * u.y, sin_phi, cos_phi; /* a point on the projected disk ... */
    SINCOS(phi, sin_phi, cos_phi);
    float p1 = r * cos_phi, p2 = r * sin_phi;
    float s = 0.5f * (1.0f + wh.z); /* ... warped to the visible half of it */
    p2 = (1.0f - s) * SQRT(max_f(0.0f, 1.0f - p1 * p1)) + s * p2;
    float3 nh = p1 * t1 + p2 * t2 + SQRT(max_f(0.0f, 1.0f - p1 * p1 - p2 * p2)) * wh; /* onto the hemisphere */
    return unit((float3)(alpha * nh.x, alpha * nh.y, max_f(0.0f, nh.z)));          /* unstretch */
}

/* Density of a reflected wi sampled through ggx_sample_vndf(wo): D_wo(h) / (4 |wo . h|) = G1(wo) D(h) / (4 cos_o)
 * = D(h) / (2 (cos_o + R_o)).  wo.z > 0, h the half vector (h.z > 0). */
INLINE float ggx_reflection_pdf(float3 wo, float3 h, float alpha) { return ggx_d(h, alpha) / (2.0f * (abs_f(wo.z) + ggx_r(wo, alpha))); }

/* ---- GGX conductor: f = F D G2 / (4 cos_o cos_i), F Schlick's with an RGB F0 at |wo . h|.
 * eval = F D G2 / (4 cos_o) = F D cos_i / (2 (R_o cos_i + R_i cos_o)); weight = F G2 / G1(wo). */
INLINE float3 conductor_eval(float3 wo, float3 wi, float3 f0, float alpha, int smith) {
    if (wo.z <= 0.0f || wi.z <= 0.0f) return (float3)(0.0f);
    alpha = max_f(alpha, GGX_ALPHA_MIN);
    float3 h = unit(wo + wi);
    if (smith == SMITH_SEPARABLE) return fresnel_schlick(f0, dot3(wo, h)) * ggx_reflection_value(wo, wi, h, alpha, smith);
    float den = ggx_r(wo, alpha) * wi.z + ggx_r(wi, alpha) * wo.z;
    return fresnel_schlick(f0, dot3(wo, h)) * (ggx_d(h, alpha) * wi.z / (2.0f * den));
}

INLINE float conductor_pdf(float3 wo, float3 wi, float alpha) {
    if (wo.z <= 0.0f || wi.z <= 0.0f) return 0.0f;
    return ggx_reflection_pdf(wo, unit(wo + wi), max_f(alpha, GGX_ALPHA_MIN));
}

INLINE BsdfSample conductor_sample(float3 wo, float2 u2, float3 f0, float alpha, int smith) {
    BsdfSample s = no_sample();
    if (wo.z <= 0.0f) return s;
    alpha = max_f(alpha, GGX_ALPHA_MIN);
    float3 h = ggx_sample_vndf(wo, alpha, u2);
    float3 wi = mirror_about(wo, h);
    if (wi.z <= 0.0f || h.z <= 0.0f) return s; /* reflected below the surface: the energy single scattering loses */
    float ro = ggx_r(wo, alpha), ri = ggx_r(wi, alpha);
    s.wi = wi;
    s.pdf = ggx_reflection_pdf(wo, h, alpha);
    s.weight = fresnel_schlick(f0, dot3(wo, h)) * (wi.z * (wo.z + ro) / (ro * wi.z + ri * wo.z)); /* F G2 / G1(wo) */
    if (smith == SMITH_SEPARABLE) s.weight = fresnel_schlick(f0, dot3(wo, h)) * ggx_g1(wi, alpha);
    return s;
}

/* ---- smooth dielectric: a delta reflection (probability F) and a delta refraction (probability 1 - F),
 * F the exact Fresnel reflectance at wo; weights 1 and (eta_o / eta_i)^2.  eval and pdf are 0. */
INLINE BsdfSample dielectric_sample(float3 wo, float u1, float eta) {
    BsdfSample s = no_sample();
    if (wo.z == 0.0f) return s;
    float cos_t;
    float f = fresnel_dielectric(wo.z, eta, &cos_t);
    s.delta = 1;
    if (u1 < f) {
        s.wi = (float3)(-wo.x, -wo.y, wo.z);
        s.weight = (float3)(1.0f);
        s.pdf = f;
        return s;
    }
    bool outside = wo.z > 0.0f;
    float eta_rel = outside ? eta : 1.0f / eta; /* eta_i / eta_o: wi's side over wo's side */
    float side = outside ? 1.0f : -1.0f;
    s.wi = unit(-wo / eta_rel + (abs_f(wo.z) / eta_rel - cos_t) * (float3)(0.0f, 0.0f, side));
    s.weight = (float3)(1.0f / (eta_rel * eta_rel));
    s.pdf = 1.0f - f;
    s.eta = eta_rel;
    return s;
}

/* Shared by the rough dielectric's eval and pdf: the generalised half vector of (wo, wi) (Walter et al. 2007):
 * h = wo + wi for reflection, eta_o wo + eta_i wi for transmission, turned to +z; *len2 gets the squared length
 * of the unnormalised transmission vector (= (eta_i wi.h + eta_o wo.h)^2, the Jacobian's denominator).
 * Returns 0 when the pair cannot scatter: a grazing direction, eta = 1, a degenerate h, or a microfacet that
 * faces away from wo or wi. */
INLINE int dielectric_half(float3 wo, float3 wi, float eta, float3 *h, float *eta_o, float *eta_i, float *len2) {
    bool index_matched = eta == 1.0f; /* a delta pass-through (rough_dielectric_sample): nothing to evaluate */
    if (wo.z == 0.0f || wi.z == 0.0f || index_matched) return 0;
    bool reflect = wo.z * wi.z > 0.0f;
    *eta_o = wo.z > 0.0f ? 1.0f : eta;
    *eta_i = wi.z > 0.0f ? 1.0f : eta;
    float3 v = reflect ? wo + wi : *eta_o * wo + *eta_i * wi;
    *len2 = dot3(v, v);
    if (!(*len2 > 0.0f)) return 0;
    v = v / SQRT(*len2);
    *h = v.z < 0.0f ? -v : v;
    bool facing = dot3(wo, *h) * wo.z > 0.0f && dot3(wi, *h) * wi.z > 0.0f;
    return facing;
}

/* The direction whose cosine to h Fresnel takes: wo, except for a transmission out of the denser side, where wi
 * (on the less dense side) is used.  Across the interface both give the same F, but near the critical angle
 * 1 - F computed from the denser side amplifies that cosine's rounding a thousandfold; from the other side it is
 * linear in a cosine near 0. */
INLINE float3 fresnel_side(float3 wo, float3 wi, float eta) {
    bool transmission = wo.z * wi.z < 0.0f;
    bool wo_denser = (wo.z < 0.0f) == (eta > 1.0f);
    return transmission && wo_denser ? wi : wo;
}

/* ---- rough dielectric (Walter et al. 2007), GGX, exact Fresnel F at wo . h (fresnel_side):
 *   reflection:   f = F D G2 / (4 |cos_o| |cos_i|)
 *   transmission: f = (1 - F) D G2 |wi.h| |wo.h| eta_o^2 / (|cos_o| |cos_i| (eta_i wi.h + eta_o wo.h)^2)
 * (the radiance form: eta_o^2 in the numerator).  Sampling: h from the visible normals of wo (flipped to +z),
 * reflect with probability F, else refract.  eta = 1 is sampled as the smooth lobe (straight through, delta). */
INLINE float3 rough_dielectric_eval(float3 wo, float3 wi, float eta, float alpha, int smith) {
    float3 h;
    float eta_o, eta_i, len2, cos_t;
    if (!dielectric_half(wo, wi, eta, &h, &eta_o, &eta_i, &len2)) return (float3)(0.0f);
    alpha = max_f(alpha, GGX_ALPHA_MIN);
    float co = abs_f(wo.z), ci = abs_f(wi.z);
    float d_g2_over_co = ggx_d(h, alpha) * 2.0f * ci / (ggx_r(wo, alpha) * ci + ggx_r(wi, alpha) * co); /* D G2 / cos_o */
    if (smith == SMITH_SEPARABLE) d_g2_over_co = ggx_d(h, alpha) * ggx_g2_separable(wo, wi, alpha) / co;
    float f = fresnel_dielectric(dot3(fresnel_side(wo, wi, eta), h), eta, &cos_t);
    if (wo.z * wi.z > 0.0f) return (float3)(f * d_g2_over_co * 0.25f);
    float jacobian = abs_f(dot3(wi, h)) * abs_f(dot3(wo, h)) * eta_o * eta_o / len2;
    return (float3)((1.0f - f) * d_g2_over_co * jacobian);
}

INLINE float rough_dielectric_pdf(float3 wo, float3 wi, float eta, float alpha) {
    float3 h;
    float eta_o, eta_i, len2, cos_t;
    if (!dielectric_half(wo, wi, eta, &h, &eta_o, &eta_i, &len2)) return 0.0f;
    alpha = max_f(alpha, GGX_ALPHA_MIN);
    float f = fresnel_dielectric(dot3(fresnel_side(wo, wi, eta), h), eta, &cos_t);
    float visible = ggx_d(h, alpha) / (abs_f(wo.z) + ggx_r(wo, alpha)); /* D_wo(h) / (2 |wo . h|) */
    if (wo.z * wi.z > 0.0f) return f * visible * 0.5f;                  /* D_wo(h) / (4 |wo . h|) */
    float dh_dwi = eta_i * eta_i * abs_f(dot3(wi, h)) / len2;            /* Walter's eq. 17 */
    return (1.0f - f) * visible * 2.0f * abs_f(dot3(wo, h)) * dh_dwi;
}

INLINE BsdfSample rough_dielectric_sample(float3 wo, float u1, float2 u2, float eta, float alpha, int smith) {
    BsdfSample s = no_sample();
    if (wo.z == 0.0f) return s;
    bool index_matched = eta == 1.0f; /* no interface: light passes straight through, a delta (h is undefined) */
    if (index_matched) return dielectric_sample(wo, u1, eta);
    alpha = max_f(alpha, GGX_ALPHA_MIN);
    float side = wo.z > 0.0f ? 1.0f : -1.0f;
    float3 h = ggx_sample_vndf(wo * side, alpha, u2);
    float cos_oh = dot3(wo, h); /* same sign as wo.z */
    if (h.z <= 0.0f || cos_oh * side <= 0.0f) return s;
    float cos_t;
    float f = fresnel_dielectric(cos_oh, eta, &cos_t);
    bool reflect = u1 < f; /* always under total internal reflection (f = 1) */
    float eta_rel = reflect ? 1.0f : (side > 0.0f ? eta : 1.0f / eta); /* eta_i / eta_o */
    float3 h_o = h * side;                                               /* h on wo's side */
    float3 wi = reflect ? mirror_about(wo, h) : unit(-wo / eta_rel + (abs_f(cos_oh) / eta_rel - cos_t) * h_o);
    bool on_its_side = reflect ? wi.z * side > 0.0f : wi.z * side < 0.0f;
    if (!on_its_side) return s;
    float co = abs_f(wo.z), ci = abs_f(wi.z), ro = ggx_r(wo, alpha);
    s.wi = wi;
    s.weight = (float3)(ci * (co + ro) / (ro * ci + ggx_r(wi, alpha) * co) / (eta_rel * eta_rel)); /* G2 / G1(wo) / eta^2 */
    if (smith == SMITH_SEPARABLE) s.weight = (float3)(ggx_g1(wi, alpha) / (eta_rel * eta_rel));
    s.eta = eta_rel;
    s.pdf = rough_dielectric_pdf(wo, wi, eta, alpha); /* from wi, as the integrator's MIS will see it */
    if (!(s.pdf > 0.0f)) return no_sample();
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
INLINE float gltf_specular_probability(float3 wo, float3 base, float metallic) {
    float s = pow5(1.0f - wo.z);
    float f_d = GLTF_DIELECTRIC_F0 + (1.0f - GLTF_DIELECTRIC_F0) * s;
    float e_s = (1.0f - metallic) * f_d + metallic * mean3(fresnel_schlick(base, wo.z));
    float e_d = (1.0f - metallic) * (1.0f - f_d) * mean3(base);
    if (!(e_d > 0.0f)) return 1.0f;
    return CLAMP(e_s / (e_s + e_d), GLTF_LOBE_PROB_MIN, 1.0f - GLTF_LOBE_PROB_MIN);
}

INLINE float3 gltf_eval(float3 wo, float3 wi, float3 base, float metallic, float alpha, int smith) {
    if (wo.z <= 0.0f || wi.z <= 0.0f) return (float3)(0.0f);
    alpha = max_f(alpha, GGX_ALPHA_MIN);
    float3 h = unit(wo + wi);
    float c = dot3(wo, h);
    float specular = ggx_d(h, alpha) * wi.z / (2.0f * (ggx_r(wo, alpha) * wi.z + ggx_r(wi, alpha) * wo.z)); /* D G2 / (4 cos_o) */
    if (smith == SMITH_SEPARABLE) specular = ggx_reflection_value(wo, wi, h, alpha, smith);
    float f_d = GLTF_DIELECTRIC_F0 + (1.0f - GLTF_DIELECTRIC_F0) * pow5(1.0f - c);
    float3 dielectric = (1.0f - f_d) * base * (wi.z * M_1_PI_F) + (float3)(f_d * specular);
    float3 metal = fresnel_schlick(base, c) * specular;
    return (1.0f - metallic) * dielectric + metallic * metal;
}

INLINE float gltf_pdf(float3 wo, float3 wi, float3 base, float metallic, float alpha) {
    if (wo.z <= 0.0f || wi.z <= 0.0f) return 0.0f;
    float p_spec = gltf_specular_probability(wo, base, metallic);
    return p_spec * conductor_pdf(wo, wi, alpha) + (1.0f - p_spec) * lambert_pdf(wo, wi);
}

INLINE BsdfSample gltf_sample(float3 wo, float u1, float2 u2, float3 base, float metallic, float alpha, int smith) {
    BsdfSample s = no_sample();
    if (wo.z <= 0.0f) return s;
    float p_spec = gltf_specular_probability(wo, base, metallic);
    float3 wi = u1 < p_spec ? mirror_about(wo, ggx_sample_vndf(wo, max_f(alpha, GGX_ALPHA_MIN), u2)) : cosine_hemisphere(u2);
    if (wi.z <= 0.0f) return s;
    float pdf = gltf_pdf(wo, wi, base, metallic, alpha);
    if (!(pdf > 0.0f)) return s;
    s.wi = wi;
    s.pdf = pdf;
    s.weight = gltf_eval(wo, wi, base, metallic, alpha, smith) / pdf;
    return s;
}

/* ---- mirror: a perfect mirror of reflectance `colour` (the Phong material's mirror share; a delta: eval and pdf 0) */
INLINE BsdfSample mirror_sample(float3 wo, float3 colour) {
    BsdfSample s = no_sample();
    if (wo.z <= 0.0f) return s;
    s.wi = (float3)(-wo.x, -wo.y, wo.z);
    s.weight = colour;
    s.pdf = 1.0f;
    s.delta = 1;
    return s;
}

/* ---- phong: the Phong material's Lambert-plus-glossy mix, f cos = Lambert(colour = kd) + ks x the GGX conductor with
 * F = 1 (tint = ks, alpha its width, SMITH_CORRELATED), kd + ks <= 1 per channel (material.h scales them).
 * Sampling: the glossy lobe (visible normals) with probability specular_prob, else the cosine-weighted Lambert;
 * pdf the mixture, a sample's weight the sum's value over that mixture pdf. */
INLINE float3 phong_eval(float3 wo, float3 wi, BsdfParams p) {
    float3 f = lambert_eval(wo, wi, p.colour);
    f += p.tint * conductor_eval(wo, wi, (float3)(1.0f), p.alpha, SMITH_CORRELATED);
    return f;
}

INLINE float phong_pdf(float3 wo, float3 wi, BsdfParams p) {
    float pdf = lambert_pdf(wo, wi);
    pdf = (1.0f - p.specular_prob) * pdf + p.specular_prob * conductor_pdf(wo, wi, p.alpha);
    return pdf;
}

INLINE BsdfSample phong_sample(float3 wo, float u1, float2 u2, BsdfParams p) {
    BsdfSample s = u1 < p.specular_prob ? conductor_sample(wo, u2, (float3)(1.0f), p.alpha, SMITH_CORRELATED)
                                        : lambert_sample(wo, u2, p.colour);
    if (!(s.pdf > 0.0f)) return no_sample();
    s.pdf = phong_pdf(wo, s.wi, p);
    if (!(s.pdf > 0.0f)) return no_sample();
    s.weight = phong_eval(wo, s.wi, p) / s.pdf;
    return s;
}

/* The dielectrics' specular transmittance (Mitsuba's specular_transmittance; glTF glass's base colour, which
 * KHR_materials_transmission puts on the BTDF only): a value or weight times transmit_tint for a pair of
 * directions through the surface, untouched on reflection. */
INLINE float3 transmission_tinted(float3 v, float3 wo, float3 wi, BsdfParams p) { return wo.z * wi.z < 0.0f ? v * p.transmit_tint : v; }

/* the lobes Mitsuba and pbrt scenes need: metal, coated diffuse, thin dielectric */
#include "bsdf_exchange.h"

/* ---------------------------------------------------------------- the dispatch
 * The lobe a material picked at a vertex, with its parameters: what the integrator samples and evaluates. */
typedef struct {
    int lobe; /* a BSDF_* code */
    BsdfParams bsdf;
} Component;

/* Delta lobes: eval and pdf are 0, their samples carry `delta`, and light sampling cannot reach them (no NEE). */
INLINE bool component_is_delta(Component c) {
    return c.lobe == BSDF_MIRROR || c.lobe == BSDF_DIELECTRIC || c.lobe == BSDF_METAL_SMOOTH || c.lobe == BSDF_THIN_DIELECTRIC;
}

/* The lobes whose eta is inside over outside: their frame's +z must point out of the object (material.h). */
INLINE bool component_is_dielectric(Component c) { return c.lobe == BSDF_DIELECTRIC || c.lobe == BSDF_ROUGH_DIELECTRIC; }

/* f * |cos theta_i| of the component, local frame (delta lobes: 0). */
INLINE float3 component_eval(Component c, float3 wo, float3 wi) {
    int lobe = c.lobe;
    BsdfParams p = c.bsdf;
    if (lobe == BSDF_LAMBERT) return lambert_eval(wo, wi, p.colour);
    if (lobe == BSDF_PHONG) return phong_eval(wo, wi, p);
    if (lobe == BSDF_CONDUCTOR) return conductor_eval(wo, wi, p.colour, p.alpha, p.smith);
    if (lobe == BSDF_ROUGH_DIELECTRIC) return transmission_tinted(rough_dielectric_eval(wo, wi, p.eta, p.alpha, p.smith), wo, wi, p);
    if (lobe == BSDF_GLTF) return gltf_eval(wo, wi, p.colour, p.metallic, p.alpha, p.smith);
    if (lobe == BSDF_METAL) return metal_eval(wo, wi, p);
    if (lobe == BSDF_COATED_DIFFUSE) return coated_eval(wo, wi, p);
    if (lobe == BSDF_COATED_DIFFUSE_SMOOTH) return coated_smooth_eval(wo, wi, p);
    return (float3)(0.0f); /* the delta lobes */
}

/* The solid-angle density of component_sample's wi (delta lobes: 0). */
INLINE float component_pdf(Component c, float3 wo, float3 wi) {
    int lobe = c.lobe;
    BsdfParams p = c.bsdf;
    if (lobe == BSDF_LAMBERT) return lambert_pdf(wo, wi);
    if (lobe == BSDF_PHONG) return phong_pdf(wo, wi, p);
    if (lobe == BSDF_CONDUCTOR) return conductor_pdf(wo, wi, p.alpha);
    if (lobe == BSDF_ROUGH_DIELECTRIC) return rough_dielectric_pdf(wo, wi, p.eta, p.alpha);
    if (lobe == BSDF_GLTF) return gltf_pdf(wo, wi, p.colour, p.metallic, p.alpha);
    if (lobe == BSDF_METAL) return conductor_pdf(wo, wi, p.alpha);
    if (lobe == BSDF_COATED_DIFFUSE) return coated_pdf(wo, wi, p);
    if (lobe == BSDF_COATED_DIFFUSE_SMOOTH) return coated_smooth_pdf(wo, wi, p);
    return 0.0f;
}

/* One direction wi from the component: u1 picks a sub-lobe or reflection vs transmission, u2 places wi. */
INLINE BsdfSample component_sample(Component c, float3 wo, float u1, float2 u2) {
    int lobe = c.lobe;
    BsdfParams p = c.bsdf;
    BsdfSample s;
    if (lobe == BSDF_LAMBERT) return lambert_sample(wo, u2, p.colour);
    if (lobe == BSDF_PHONG) return phong_sample(wo, u1, u2, p);
    if (lobe == BSDF_MIRROR) return mirror_sample(wo, p.colour);
    if (lobe == BSDF_CONDUCTOR) return conductor_sample(wo, u2, p.colour, p.alpha, p.smith);
    if (lobe == BSDF_DIELECTRIC || lobe == BSDF_ROUGH_DIELECTRIC) {
        s = lobe == BSDF_DIELECTRIC ? dielectric_sample(wo, u1, p.eta) : rough_dielectric_sample(wo, u1, u2, p.eta, p.alpha, p.smith);
        s.weight = transmission_tinted(s.weight, wo, s.wi, p);
        return s;
    }
    if (lobe == BSDF_GLTF) return gltf_sample(wo, u1, u2, p.colour, p.metallic, p.alpha, p.smith);
    if (lobe == BSDF_METAL) return metal_sample(wo, u2, p);
    if (lobe == BSDF_METAL_SMOOTH) return metal_smooth_sample(wo, p);
    if (lobe == BSDF_COATED_DIFFUSE) return coated_sample(wo, u1, u2, p);
    if (lobe == BSDF_COATED_DIFFUSE_SMOOTH) return coated_smooth_sample(wo, u1, u2, p);
    if (lobe == BSDF_THIN_DIELECTRIC) return thin_dielectric_sample(wo, u1, p);
    return no_sample();
}

#endif
