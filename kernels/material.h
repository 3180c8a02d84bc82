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

INLINE float luminance(float3 c) { return 0.2126f * c.x + 0.7152f * c.y + 0.0722f * c.z; }

/* The Phong exponent s as a GGX width: alpha = sqrt(2 / (s + 2)) (Walter et al. 2007's match of the two lobes' widths). */
INLINE float alpha_from_shininess(float s) { return max_f(sqrt(2.0f / (s + 2.0f)), GGX_ALPHA_MIN); }

/* A `type = ...` material (MATERIAL_MODEL_CONDUCTOR and after): one lobe of bsdf_exchange.h, its parameters from the
 * record; roughness 0 is the lobe's smooth (delta) form. */
INLINE Component exchange_component(Component c, const MaterialPoint *m) {
    __global const Material *g = m->g;
    bool smooth = !(m->roughness > 0.0f);
    c.bsdf.alpha = ggx_alpha_from_roughness(m->roughness);
    c.bsdf.eta = g->lobe_ior;
    c.bsdf.eta3 = vload3(0, g->eta);
    c.bsdf.k3 = vload3(0, g->k);
    c.bsdf.tint = vload3(0, g->tint);
    c.bsdf.transmit_tint = vload3(0, g->transmit_tint);
    c.bsdf.nonlinear = g->nonlinear;
    c.bsdf.coat_weight = g->coat_weight;
    c.bsdf.coat_internal = g->coat_internal;
    c.bsdf.coat_tables = g->coat_transmittance;
    c.bsdf.coat_table = 0;
    if (m->model == MATERIAL_MODEL_CONDUCTOR) c.lobe = smooth ? BSDF_METAL_SMOOTH : BSDF_METAL;
    else if (m->model == MATERIAL_MODEL_COATED_DIFFUSE) c.lobe = smooth ? BSDF_COATED_DIFFUSE_SMOOTH : BSDF_COATED_DIFFUSE;
    else c.lobe = BSDF_THIN_DIELECTRIC;
    return c;
}

/* glTF's metallic-roughness material: its transmission share a dielectric (KHR_materials_transmission: the BTDF times
 * base_color), the rest glTF's BRDF. */
INLINE Component gltf_component(Component c, const MaterialPoint *m, float u) {
    float alpha = ggx_alpha_from_roughness(m->roughness);
    c.bsdf.alpha = alpha;
    float transmit = m->transmission * (1.0f - m->metallic);
    if (u < transmit) {
        c.lobe = m->roughness > 0.0f ? BSDF_ROUGH_DIELECTRIC : BSDF_DIELECTRIC;
        c.bsdf.transmit_tint = m->base_color;
        return c;
    }
    c.lobe = BSDF_GLTF;
    c.bsdf.colour = m->base_color;
    return c;
}

/* The Phong material (the Whitted keys): clear glass, a mirror, and Lambert kd plus a glossy GGX lobe ks, kd and ks
 * scaled together where kd + ks would exceed 1. */
INLINE Component phong_component(Component c, const MaterialPoint *m, float u) {
    float t = m->transparency, mirror = (1.0f - t) * m->mirror;
    if (u < t) { c.lobe = BSDF_DIELECTRIC; return c; }
    if (u < t + mirror) { c.lobe = BSDF_MIRROR; c.bsdf.colour = v3_all(1.0f); return c; }
    float3 kd = m->kd, ks = m->ks;
    float3 sum = kd + ks;
    float over = max_f(1.0f, max3(sum));
    kd /= over; ks /= over;
    c.lobe = BSDF_LAMBERT;
    c.bsdf.colour = kd;
    float lk = luminance(ks), ld = luminance(kd);
    if (lk > 0.0f) {
        c.lobe = BSDF_PHONG;
        c.bsdf.tint = ks;
        c.bsdf.alpha = alpha_from_shininess(m->shininess);
        c.bsdf.specular_prob = lk / (lk + ld);
    }
    return c;
}

/* The vertex's component: one lobe of its material type's set, picked by u. */
INLINE Component pick_component(const MaterialPoint *m, float u) {
    Component c;
    c.bsdf.transmit_tint = v3_all(1.0f);
    c.bsdf.eta = m->ior; /* inside over outside (bsdf.h, the frame's +z outward): objects do not nest, outside is air */
    c.bsdf.metallic = m->metallic;
    c.bsdf.colour = m->kd;
    c.bsdf.smith = m->g->smith;
    if (m->model >= MATERIAL_MODEL_CONDUCTOR) return exchange_component(c, m);
    if (m->model == MATERIAL_MODEL_GLTF) return gltf_component(c, m, u);
    return phong_component(c, m, u);
}

/* The component's local frame at f: +z on the ray's side for reflection, outward for dielectrics (bsdf.h's eta). */
INLINE Frame component_frame(Component c, const Surface *f) {
    return make_frame(component_is_dielectric(c) && !f->front ? -f->n_shade : f->n_shade);
}

#endif
