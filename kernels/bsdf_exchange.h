/* The lobes that Mitsuba 3 and pbrt-v4 scenes need (issue 36), with bsdf.h's conventions (wo, wi away from the
 * surface in the local frame, eval = f |cos theta_i|, weight = eval / pdf).  Included by bsdf.h, after the GGX
 * helpers; docs/materials.md describes each one and its keys.
 *   metal                  GGX conductor with the exact Fresnel reflectance of a complex IOR eta + i k per channel
 *                          (Mitsuba's roughconductor, pbrt's conductor), times `tint`
 *   metal_smooth           its delta mirror (Mitsuba's conductor)
 *   coated_diffuse         a diffuse base under a rough dielectric coat (Mitsuba's roughplastic)
 *   coated_diffuse_smooth  the same under a smooth coat (Mitsuba's plastic): a delta reflection plus a diffuse lobe
 *   thin_dielectric        a thin sheet (Mitsuba's thindielectric): delta reflection with the sheet's summed
 *                          inter-reflections R' = R + T^2 R / (1 - R^2), delta transmission straight through */
#ifndef CLRENDER_BSDF_EXCHANGE_H
#define CLRENDER_BSDF_EXCHANGE_H

/* Exact unpolarised reflectance of a conductor of complex relative IOR eta + i k at incidence cos_i in [0, 1]
 * (Mitsuba 3's fresnel_conductor, after Moeller's "Optics"): with a^2 + b^2 = sqrt((eta^2 - k^2 - sin^2)^2 + 4 eta^2 k^2),
 * a = sqrt((a^2 + b^2 + eta^2 - k^2 - sin^2) / 2), r_s = (a^2 + b^2 + cos^2 - 2 a cos) / (... + 2 a cos),
 * r_p = r_s (cos^2 (a^2 + b^2) + sin^4 - 2 a cos sin^2) / (... + ...). */
INLINE float fresnel_conductor(float cos_i, float eta, float k) {
    float c2 = cos_i * cos_i, s2 = 1.0f - c2, s4 = s2 * s2;
    float temp = eta * eta - k * k - s2;
    float a2_b2 = SQRT(max_f(0.0f, temp * temp + 4.0f * k * k * eta * eta));
    float a = SQRT(max_f(0.0f, 0.5f * (a2_b2 + temp)));
    float term1 = a2_b2 + c2, term2 = 2.0f * cos_i * a;
    float term3 = a2_b2 * c2 + s4, term4 = term2 * s2;
    bool grazing_match = !(term1 + term2 > 0.0f) || !(term3 + term4 > 0.0f); /* eta = 1, k = 0 at cos 0: the limit 1 */
    if (grazing_match) return 1.0f;
    float r_s = (term1 - term2) / (term1 + term2);
    float r_p = r_s * (term3 - term4) / (term3 + term4);
    return 0.5f * (r_s + r_p);
}

INLINE float3 metal_fresnel(float cos_i, BsdfParams p) {
    float3 f = (float3)(fresnel_conductor(cos_i, p.eta3.x, p.k3.x), fresnel_conductor(cos_i, p.eta3.y, p.k3.y),
                        fresnel_conductor(cos_i, p.eta3.z, p.k3.z));
    return p.tint * f;
}

/* ---- metal: f = tint F(wo . h) D G / (4 cos_o cos_i), visible-normal sampling (weight tint F G / G1(wo)) */
INLINE float3 metal_eval(float3 wo, float3 wi, BsdfParams p) {
    if (wo.z <= 0.0f || wi.z <= 0.0f) return (float3)(0.0f);
    float alpha = max_f(p.alpha, GGX_ALPHA_MIN);
    float3 h = unit(wo + wi);
    return metal_fresnel(dot3(wo, h), p) * ggx_reflection_value(wo, wi, h, alpha, p.smith);
}

INLINE BsdfSample metal_sample(float3 wo, float2 u2, BsdfParams p) {
    BsdfSample s = no_sample();
    if (wo.z <= 0.0f) return s;
    float alpha = max_f(p.alpha, GGX_ALPHA_MIN);
    float3 h = ggx_sample_vndf(wo, alpha, u2);
    float3 wi = mirror_about(wo, h);
    if (wi.z <= 0.0f || h.z <= 0.0f) return s;
    s.wi = wi;
    s.pdf = ggx_reflection_pdf(wo, h, alpha);
    s.weight = metal_fresnel(dot3(wo, h), p) * ggx_reflection_weight(wo, wi, alpha, p.smith);
    return s;
}

/* ---- metal_smooth: the mirror direction with probability 1, weight tint F(cos_o) (a delta: eval and pdf 0) */
INLINE BsdfSample metal_smooth_sample(float3 wo, BsdfParams p) {
    BsdfSample s = no_sample();
    if (wo.z <= 0.0f) return s;
    s.wi = (float3)(-wo.x, -wo.y, wo.z);
    s.weight = metal_fresnel(wo.z, p);
    s.pdf = 1.0f;
    s.delta = 1;
    return s;
}

/* ---- the coated diffuse (Mitsuba's plastic and roughplastic), eta = coat IOR inside / outside:
 *   diffuse part  f_d = base / (1 - fdr) (1 / eta^2) T(cos_o) T(cos_i) / pi, with fdr the coat's internal diffuse
 *                 reflectance (times the base for `nonlinear`) and T the coat's transmittance: 1 - F(cos) for the
 *                 smooth coat, the rough coat's table (Mitsuba's external transmittance, a lerp of COAT_TABLE_RES values)
 *   specular part tint F times a delta mirror (smooth) or tint F(wo . h) D G / (4 cos_o cos_i) (rough)
 * Sampling: the specular part with probability p_s = E_s w / (E_s w + (1 - E_s)(1 - w)), w = coat_weight, E_s the
 * coat's reflectance at cos_o (F(cos_o) smooth, 1 - T(cos_o) rough), else the cosine-weighted diffuse. */
INLINE float3 coat_base(BsdfParams p) {
    float3 internal = p.nonlinear ? p.colour * p.coat_internal : (float3)(p.coat_internal);
    return p.colour / ((float3)(1.0f) - internal);
}

INLINE float coat_specular_probability(float e_s, float w) {
    float p_s = e_s * w, p_d = (1.0f - e_s) * (1.0f - w);
    return p_s + p_d > 0.0f ? p_s / (p_s + p_d) : 1.0f;
}

INLINE float coat_fresnel(float cos_i, float eta) {
    float cos_t;
    return fresnel_dielectric(cos_i, eta, &cos_t);
}

/* Mitsuba's lerp_gather of the transmittance table at cos in [0, 1]. */
INLINE float coat_transmittance_at(__global const float *table, float cos_theta) {
    float x = cos_theta * (float)(COAT_TABLE_RES - 1);
    int i = min((int)x, COAT_TABLE_RES - 2);
    float w1 = x - (float)i;
    return (1.0f - w1) * table[i] + w1 * table[i + 1];
}

INLINE float3 coated_smooth_eval(float3 wo, float3 wi, BsdfParams p) {
    if (wo.z <= 0.0f || wi.z <= 0.0f) return (float3)(0.0f);
    float t_o = 1.0f - coat_fresnel(wo.z, p.eta), t_i = 1.0f - coat_fresnel(wi.z, p.eta);
    return coat_base(p) * (wi.z * M_1_PI_F * t_o * t_i / (p.eta * p.eta));
}

INLINE float coated_smooth_pdf(float3 wo, float3 wi, BsdfParams p) {
    if (wo.z <= 0.0f || wi.z <= 0.0f) return 0.0f;
    return (1.0f - coat_specular_probability(coat_fresnel(wo.z, p.eta), p.coat_weight)) * wi.z * M_1_PI_F;
}

INLINE BsdfSample coated_smooth_sample(float3 wo, float u1, float2 u2, BsdfParams p) {
    BsdfSample s = no_sample();
    if (wo.z <= 0.0f) return s;
    float f_o = coat_fresnel(wo.z, p.eta);
    float p_spec = coat_specular_probability(f_o, p.coat_weight);
    if (u1 < p_spec) {
        s.wi = (float3)(-wo.x, -wo.y, wo.z);
        s.pdf = p_spec;
        s.weight = p.tint * (f_o / p_spec);
        s.delta = 1;
        return s;
    }
    float3 wi = cosine_hemisphere(u2);
    if (wi.z <= 0.0f) return s;
    float t_i = 1.0f - coat_fresnel(wi.z, p.eta);
    s.wi = wi;
    s.pdf = (1.0f - p_spec) * wi.z * M_1_PI_F;
    s.weight = coat_base(p) * ((1.0f - f_o) * t_i / (p.eta * p.eta * (1.0f - p_spec)));
    return s;
}

INLINE float3 coated_eval(float3 wo, float3 wi, BsdfParams p) {
    if (wo.z <= 0.0f || wi.z <= 0.0f) return (float3)(0.0f);
    float alpha = max_f(p.alpha, GGX_ALPHA_MIN);
    float3 h = unit(wo + wi);
    float3 specular = p.tint * (coat_fresnel(dot3(wo, h), p.eta) * ggx_reflection_value(wo, wi, h, alpha, p.smith));
    float t_o = coat_transmittance_at(p.coat_transmittance, wo.z), t_i = coat_transmittance_at(p.coat_transmittance, wi.z);
    return specular + coat_base(p) * (wi.z * M_1_PI_F * t_o * t_i / (p.eta * p.eta));
}

INLINE float coated_pdf(float3 wo, float3 wi, BsdfParams p) {
    if (wo.z <= 0.0f || wi.z <= 0.0f) return 0.0f;
    float alpha = max_f(p.alpha, GGX_ALPHA_MIN);
    float p_spec = coat_specular_probability(1.0f - coat_transmittance_at(p.coat_transmittance, wo.z), p.coat_weight);
    return p_spec * ggx_reflection_pdf(wo, unit(wo + wi), alpha) + (1.0f - p_spec) * wi.z * M_1_PI_F;
}

INLINE BsdfSample coated_sample(float3 wo, float u1, float2 u2, BsdfParams p) {
    BsdfSample s = no_sample();
    if (wo.z <= 0.0f) return s;
    float alpha = max_f(p.alpha, GGX_ALPHA_MIN);
    float p_spec = coat_specular_probability(1.0f - coat_transmittance_at(p.coat_transmittance, wo.z), p.coat_weight);
    float3 wi = u1 < p_spec ? mirror_about(wo, ggx_sample_vndf(wo, alpha, u2)) : cosine_hemisphere(u2);
    if (wi.z <= 0.0f) return s;
    float pdf = coated_pdf(wo, wi, p);
    if (!(pdf > 0.0f)) return s;
    s.wi = wi;
    s.pdf = pdf;
    s.weight = coated_eval(wo, wi, p) / pdf;
    return s;
}

/* ---- thin_dielectric: eta = the sheet's IOR over the outside's, the same seen from either side */
INLINE BsdfSample thin_dielectric_sample(float3 wo, float u1, BsdfParams p) {
    BsdfSample s = no_sample();
    if (wo.z == 0.0f) return s;
    float r = coat_fresnel(abs_f(wo.z), p.eta);
    float t = 1.0f - r;
    if (r < 1.0f) r += t * t * r / (1.0f - r * r); /* the two faces' inter-reflections, summed */
    s.delta = 1;
    if (u1 < r) {
        s.wi = (float3)(-wo.x, -wo.y, wo.z);
        s.weight = p.tint;
        s.pdf = r;
        return s;
    }
    s.wi = -wo;
    s.weight = p.transmit_tint;
    s.pdf = 1.0f - r;
    return s;
}

#endif
