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
INLINE LF fresnel_conductor(LF cos_i, LF eta, LF k) {
    LF c2 = cos_i * cos_i, s2 = 1.0f - c2, s4 = s2 * s2;
    LF temp = eta * eta - k * k - s2;
    LF a2_b2 = sqrt_l(max_l(0.0f, temp * temp + 4.0f * k * k * eta * eta));
    LF a = sqrt_l(max_l(0.0f, 0.5f * (a2_b2 + temp)));
    LF term1 = a2_b2 + c2, term2 = 2.0f * cos_i * a;
    LF term3 = a2_b2 * c2 + s4, term4 = term2 * s2;
    LI grazing_match = NOT(term1 + term2 > 0.0f) | NOT(term3 + term4 > 0.0f); /* eta = 1, k = 0 at cos 0: the limit 1 */
    LF r_s = (term1 - term2) / (term1 + term2);
    LF r_p = r_s * (term3 - term4) / (term3 + term4);
    return grazing_match ? (LF)(1.0f) : 0.5f * (r_s + r_p);
}

INLINE V3 metal_fresnel(LF cos_i, BsdfParams p) {
    V3 f = v3(fresnel_conductor(cos_i, p.eta3.x, p.k3.x), fresnel_conductor(cos_i, p.eta3.y, p.k3.y),
              fresnel_conductor(cos_i, p.eta3.z, p.k3.z));
    return vmul(p.tint, f);
}

/* ---- metal: f = tint F(wo . h) D G / (4 cos_o cos_i), visible-normal sampling (weight tint F G / G1(wo)) */
INLINE V3 metal_eval(V3 wo, V3 wi, BsdfParams p) {
    LF alpha = max_l(p.alpha, GGX_ALPHA_MIN);
    V3 h = vunit(vadd(wo, wi));
    V3 f = vscale(ggx_reflection_value(wo, wi, h, alpha, p.smith), metal_fresnel(vdot(wo, h), p));
    return vpick(both_above(wo, wi), f, v3_all(0.0f));
}

INLINE BsdfSample metal_sample(V3 wo, V2 u2, BsdfParams p) {
    LF alpha = max_l(p.alpha, GGX_ALPHA_MIN);
    V3 h;
    LI valid;
    V3 wi = ggx_reflect_sample(wo, alpha, u2, &h, &valid);
    V3 weight = vscale(ggx_reflection_weight(wo, wi, alpha, p.smith), metal_fresnel(vdot(wo, h), p));
    return keep_sample(valid, sample_of(wi, weight, ggx_reflection_pdf(wo, h, alpha)), no_sample());
}

/* ---- metal_smooth: the mirror direction with probability 1, weight tint F(cos_o) (a delta: eval and pdf 0) */
INLINE BsdfSample metal_smooth_sample(V3 wo, BsdfParams p) {
    return keep_sample(NOT(wo.z <= 0.0f), delta_reflection(wo, metal_fresnel(wo.z, p), 1.0f), no_sample());
}

/* ---- the coated diffuse (Mitsuba's plastic and roughplastic), eta = coat IOR inside / outside:
 *   diffuse part  f_d = base / (1 - fdr) (1 / eta^2) T(cos_o) T(cos_i) / pi, with fdr the coat's internal diffuse
 *                 reflectance (times the base for `nonlinear`) and T the coat's transmittance: 1 - F(cos) for the
 *                 smooth coat, the rough coat's table (Mitsuba's external transmittance, a lerp of COAT_TABLE_RES values)
 *   specular part tint F times a delta mirror (smooth) or tint F(wo . h) D G / (4 cos_o cos_i) (rough)
 * Sampling: the specular part with probability p_s = E_s w / (E_s w + (1 - E_s)(1 - w)), w = coat_weight, E_s the
 * coat's reflectance at cos_o (F(cos_o) smooth, 1 - T(cos_o) rough), else the cosine-weighted diffuse. */
INLINE V3 coat_base(BsdfParams p) {
    LF fdr = p.coat_internal;
    V3 internal = vpick(p.nonlinear, vscale(fdr, p.colour), v3(fdr, fdr, fdr));
    return v3(p.colour.x / (1.0f - internal.x), p.colour.y / (1.0f - internal.y), p.colour.z / (1.0f - internal.z));
}

INLINE LF coat_specular_probability(LF e_s, LF w) {
    LF p_s = e_s * w, p_d = (1.0f - e_s) * (1.0f - w);
    return p_s + p_d > 0.0f ? p_s / (p_s + p_d) : (LF)(1.0f);
}

INLINE LF coat_fresnel(LF cos_i, LF eta) {
    LF cos_t;
    return fresnel_dielectric(cos_i, eta, &cos_t);
}

/* Mitsuba's lerp_gather of the transmittance table at cos in [0, 1] (the index kept in the table for any cos: a lane
 * whose cos is below the surface or NaN reads the table's ends, and its answer is not kept). */
INLINE LF coat_transmittance_at(BsdfParams p, LF cos_theta) {
    LF x = cos_theta * (float)(COAT_TABLE_RES - 1);
    LI i = CONVERT_I(clamp_l(x, 0.0f, (float)(COAT_TABLE_RES - 2)));
    LF w1 = x - CONVERT_F(i);
    LI at = p.coat_table + i;
    return (1.0f - w1) * gather(p.coat_tables, at) + w1 * gather(p.coat_tables, at + 1);
}

INLINE V3 coated_smooth_eval(V3 wo, V3 wi, BsdfParams p) {
    LF t_o = 1.0f - coat_fresnel(wo.z, p.eta), t_i = 1.0f - coat_fresnel(wi.z, p.eta);
    V3 f = vscale(wi.z * M_1_PI_F * t_o * t_i / (p.eta * p.eta), coat_base(p));
    return vpick(both_above(wo, wi), f, v3_all(0.0f));
}

INLINE LF coated_smooth_pdf(V3 wo, V3 wi, BsdfParams p) {
    LF pdf = (1.0f - coat_specular_probability(coat_fresnel(wo.z, p.eta), p.coat_weight)) * wi.z * M_1_PI_F;
    return both_above(wo, wi) ? pdf : (LF)(0.0f);
}

INLINE BsdfSample coated_smooth_sample(V3 wo, LF u1, V2 u2, BsdfParams p) {
    LF f_o = coat_fresnel(wo.z, p.eta);
    LF p_spec = coat_specular_probability(f_o, p.coat_weight);
    LI specular = u1 < p_spec;
    BsdfSample s = no_sample();
    if (ANY(specular)) s = keep_sample(specular, delta_reflection(wo, vscale(f_o / p_spec, p.tint), p_spec), s);
    if (ANY(NOT(specular))) {
        V3 wi = cosine_hemisphere(u2);
        LF t_i = 1.0f - coat_fresnel(wi.z, p.eta);
        V3 weight = vscale((1.0f - f_o) * t_i / (p.eta * p.eta * (1.0f - p_spec)), coat_base(p));
        s = keep_sample(specular, s, keep_sample(NOT(wi.z <= 0.0f), sample_of(wi, weight, (1.0f - p_spec) * wi.z * M_1_PI_F), s));
    }
    return keep_sample(NOT(wo.z <= 0.0f), s, no_sample());
}

INLINE V3 coated_eval(V3 wo, V3 wi, BsdfParams p) {
    LF alpha = max_l(p.alpha, GGX_ALPHA_MIN);
    V3 h = vunit(vadd(wo, wi));
    V3 specular = vscale(coat_fresnel(vdot(wo, h), p.eta) * ggx_reflection_value(wo, wi, h, alpha, p.smith), p.tint);
    LF t_o = coat_transmittance_at(p, wo.z), t_i = coat_transmittance_at(p, wi.z);
    LF k = wi.z * M_1_PI_F * t_o * t_i / (p.eta * p.eta);
    V3 base = coat_base(p);
    V3 f = v3(specular.x + base.x * k, specular.y + base.y * k, specular.z + base.z * k);
    return vpick(both_above(wo, wi), f, v3_all(0.0f));
}

INLINE LF coated_pdf(V3 wo, V3 wi, BsdfParams p) {
    LF alpha = max_l(p.alpha, GGX_ALPHA_MIN);
    LF p_spec = coat_specular_probability(1.0f - coat_transmittance_at(p, wo.z), p.coat_weight);
    LF pdf = p_spec * ggx_reflection_pdf(wo, vunit(vadd(wo, wi)), alpha) + (1.0f - p_spec) * wi.z * M_1_PI_F;
    return both_above(wo, wi) ? pdf : (LF)(0.0f);
}

INLINE BsdfSample coated_sample(V3 wo, LF u1, V2 u2, BsdfParams p) {
    LF alpha = max_l(p.alpha, GGX_ALPHA_MIN);
    LF p_spec = coat_specular_probability(1.0f - coat_transmittance_at(p, wo.z), p.coat_weight);
    V3 wi = glossy_or_diffuse(wo, u1 < p_spec, alpha, u2);
    LF pdf = coated_pdf(wo, wi, p);
    BsdfSample s = sample_of(wi, vdiv(coated_eval(wo, wi, p), pdf), pdf);
    return keep_sample(both_above(wo, wi) & (pdf > 0.0f), s, no_sample());
}

/* ---- thin_dielectric: eta = the sheet's IOR over the outside's, the same seen from either side */
INLINE BsdfSample thin_dielectric_sample(V3 wo, LF u1, BsdfParams p) {
    LF r = coat_fresnel(abs_l(wo.z), p.eta);
    LF t = 1.0f - r;
    r = r < 1.0f ? r + t * t * r / (1.0f - r * r) : r; /* the two faces' inter-reflections, summed */
    LI reflect = u1 < r;
    BsdfSample s = delta_reflection(wo, p.tint, r);
    s.wi = vpick(reflect, s.wi, vneg(wo));
    s.weight = vpick(reflect, s.weight, p.transmit_tint);
    s.pdf = reflect ? r : 1.0f - r;
    return keep_sample(wo.z != 0.0f, s, no_sample());
}

#endif
