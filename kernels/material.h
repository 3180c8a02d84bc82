/* Materials as sets of lobes (pbrt-v4's Material::GetBxDF, with its stochastic MixMaterial): at a vertex, a material
 * point (kernels/surface.h's material_at) picks ONE of its material type's lobes with probability equal to the
 * lobe's weight (the weights sum to 1, so the throughput is not rescaled), as a Component of kernels/bsdf.h, whose
 * dispatch (component_eval, component_pdf, component_sample, component_is_delta) is all the path tracer calls.
 * docs/materials.md states the weights.  The Whitted integrator shades the same MaterialPoint by its own model
 * (kernels/shade.h).  Adding a material type: its code in clrender/layout.py's MATERIAL_MODELS and its lobe set here.
 *   phong (the Whitted keys)  transparency: dielectric; (1 - t) mirror: mirror; the rest: phong (Lambert kd plus
 *                             glossy ks), or lambert without ks
 *   gltf                      transmission (1 - metallic): dielectric or rough_dielectric tinted by base_color;
 *                             the rest: gltf
 *   conductor, coated_diffuse, thin_dielectric: one lobe each (kernels/bsdf_exchange.h), roughness 0 its delta form */
#ifndef CLRENDER_MATERIAL_H
#define CLRENDER_MATERIAL_H

#include "bsdf.h"
#include "surface.h"

INLINE LF luminance(V3 c) { return 0.2126f * c.x + 0.7152f * c.y + 0.0722f * c.z; }

/* The Phong exponent s as a GGX width: alpha = sqrt(2 / (s + 2)) (Walter et al. 2007's match of the two lobes' widths). */
INLINE LF alpha_from_shininess(LF s) { return max_l(sqrt(2.0f / (s + 2.0f)), GGX_ALPHA_MIN); }

/* A `type = ...` material (MATERIAL_MODEL_CONDUCTOR and after): one lobe of bsdf_exchange.h, its parameters from the
 * record; roughness 0 is the lobe's smooth (delta) form. */
INLINE Component exchange_component(Component c, const MaterialPoint *m) {
    __global const Material *g = m->materials;
    LI mi = m->mi, smooth = NOT(m->roughness > 0.0f);
    c.bsdf.alpha = ggx_alpha_from_roughness(m->roughness);
    c.bsdf.eta = FIELD_F(g, mi, lobe_ior);
    c.bsdf.eta3 = FIELD3(g, mi, eta);
    c.bsdf.k3 = FIELD3(g, mi, k);
    c.bsdf.tint = FIELD3(g, mi, tint);
    c.bsdf.transmit_tint = FIELD3(g, mi, transmit_tint);
    c.bsdf.nonlinear = FIELD_I(g, mi, nonlinear) != 0;
    c.bsdf.coat_weight = FIELD_F(g, mi, coat_weight);
    c.bsdf.coat_internal = FIELD_F(g, mi, coat_internal);
    c.bsdf.coat_tables = (__global const float *)g;
    c.bsdf.coat_table = mi * (int)(sizeof(Material) / 4) + (int)(__builtin_offsetof(Material, coat_transmittance) / 4);
    LI conductor = m->model == MATERIAL_MODEL_CONDUCTOR, coated = m->model == MATERIAL_MODEL_COATED_DIFFUSE;
    c.lobe = conductor ? (smooth ? (LI)(BSDF_METAL_SMOOTH) : (LI)(BSDF_METAL))
                       : coated ? (smooth ? (LI)(BSDF_COATED_DIFFUSE_SMOOTH) : (LI)(BSDF_COATED_DIFFUSE)) : (LI)(BSDF_THIN_DIELECTRIC);
    return c;
}

/* glTF's metallic-roughness material: its transmission share a dielectric (KHR_materials_transmission: the BTDF times
 * base_color), the rest glTF's BRDF. */
INLINE Component gltf_component(Component c, const MaterialPoint *m, LF u) {
    c.bsdf.alpha = ggx_alpha_from_roughness(m->roughness);
    LI transmitted = u < m->transmission * (1.0f - m->metallic);
    c.lobe = transmitted ? (m->roughness > 0.0f ? (LI)(BSDF_ROUGH_DIELECTRIC) : (LI)(BSDF_DIELECTRIC)) : (LI)(BSDF_GLTF);
    c.bsdf.transmit_tint = vpick(transmitted, m->base_color, c.bsdf.transmit_tint);
    c.bsdf.colour = vpick(transmitted, c.bsdf.colour, m->base_color);
    return c;
}

/* The Phong material (the Whitted keys): clear glass, a mirror, and Lambert kd plus a glossy GGX lobe ks, kd and ks
 * scaled together where kd + ks would exceed 1. */
INLINE Component phong_component(Component c, const MaterialPoint *m, LF u) {
    LF t = m->transparency, mirror = (1.0f - t) * m->mirror;
    LI glass = u < t, reflector = NOT(glass) & (u < t + mirror);
    V3 kd = m->kd, ks = m->ks;
    LF over = max_l(1.0f, max3_l(vadd(kd, ks)));
    kd = vdiv(kd, over); ks = vdiv(ks, over);
    LF lk = luminance(ks), ld = luminance(kd);
    LI glossy = lk > 0.0f;
    c.lobe = glass ? (LI)(BSDF_DIELECTRIC) : reflector ? (LI)(BSDF_MIRROR) : glossy ? (LI)(BSDF_PHONG) : (LI)(BSDF_LAMBERT);
    c.bsdf.colour = vpick(glass, c.bsdf.colour, vpick(reflector, v3_all(1.0f), kd));
    WHERE3(glossy, c.bsdf.tint, ks);
    WHERE(glossy, c.bsdf.alpha, alpha_from_shininess(m->shininess));
    WHERE(glossy, c.bsdf.specular_prob, lk / (lk + ld));
    return c;
}

/* The vertex's component: one lobe of its material type's set, picked by u (a masked pass per type present). */
INLINE Component pick_component(const MaterialPoint *m, LF u) {
    Component c;
    c.bsdf.transmit_tint = v3_all(1.0f);
    c.bsdf.eta = m->ior; /* inside over outside (bsdf.h, the frame's +z outward): objects do not nest, outside is air */
    c.bsdf.metallic = m->metallic;
    c.bsdf.colour = m->kd;
    c.bsdf.smith = FIELD_I(m->materials, m->mi, smith);
    c.bsdf.alpha = c.bsdf.specular_prob = c.bsdf.coat_weight = c.bsdf.coat_internal = 0.0f;
    c.bsdf.eta3 = c.bsdf.k3 = c.bsdf.tint = v3_all(1.0f);
    c.bsdf.nonlinear = c.bsdf.coat_table = 0;
    c.bsdf.coat_tables = (__global const float *)m->materials;
    c.lobe = BSDF_LAMBERT;
    LI exchange = m->model >= MATERIAL_MODEL_CONDUCTOR, gltf = m->model == MATERIAL_MODEL_GLTF;
    if (ANY(exchange)) c = keep_component(exchange, exchange_component(c, m), c);
    if (ANY(gltf)) c = keep_component(gltf, gltf_component(c, m, u), c);
    if (ANY(NOT(exchange | gltf))) c = keep_component(NOT(exchange | gltf), phong_component(c, m, u), c);
    return c;
}

/* The component's local frame at f: +z on the ray's side for reflection, outward for dielectrics (bsdf.h's eta). */
INLINE Frame component_frame(Component c, const Surface *f) {
    return make_frame(vpick(component_is_dielectric(c) & NOT(f->front), vneg(f->n_shade), f->n_shade));
}

#endif
