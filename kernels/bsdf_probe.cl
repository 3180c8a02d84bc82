/* Test-only kernels: the BSDF lobes of bsdf.h over batches, for tests/test_bsdf*.py through
 * clrender/trace/bsdf.py, through the dispatch the path tracer calls (component_eval, component_pdf,
 * component_sample): a Component of the given lobe code and parameters.
 *   params  BsdfProbeParams records (clrender/layout.py); record i * params_stride
 *   wo, wi  float4 per item (xyz, unused); wo read at i * wo_stride (stride 0: one shared by all)
 *   u       float4 per item: (u1, u2.x, u2.y, unused)
 * Build with clrender.trace.bsdf.bsdf_defines() (common.h's traversal knobs). */
#define DET_MATH 1 /* as path.cl: the lobes the path tracer runs */
#include "mathf.h"
#include "common.h"
#include "rng.h"
#include "bsdf.h"

INLINE Component probe_component(int lobe, __global const BsdfProbeParams *r) {
    Component c;
    c.lobe = lobe;
    BsdfParams p;
    p.colour = vload3(0, r->colour);
    p.alpha = r->alpha;
    p.eta = r->eta;
    p.metallic = r->metallic;
    p.smith = (int)r->smith;
    p.nonlinear = (int)r->nonlinear;
    p.eta3 = vload3(0, r->eta3);
    p.k3 = vload3(0, r->k3);
    p.tint = vload3(0, r->tint);
    p.transmit_tint = vload3(0, r->transmit_tint);
    p.coat_weight = r->coat_weight;
    p.coat_internal = r->coat_internal;
    p.coat_transmittance = r->coat_transmittance;
    p.specular_prob = r->specular_prob;
    c.bsdf = p;
    return c;
}

/* out[i] = (eval(wo, wi), 0) of lobe `lobe`: f * |cos theta_i| */
__kernel void bsdf_eval_probe(int n, int lobe, __global const BsdfProbeParams *params, int params_stride, __global const float4 *wo,
                              int wo_stride, __global const float4 *wi, __global float4 *out) {
    int i = get_global_id(0);
    if (i >= n) return;
    Component c = probe_component(lobe, params + (size_t)i * params_stride);
    out[i] = (float4)(component_eval(c, wo[(size_t)i * wo_stride].xyz, wi[i].xyz), 0.0f);
}

/* out[i] = pdf(wo, wi), solid angle */
__kernel void bsdf_pdf_probe(int n, int lobe, __global const BsdfProbeParams *params, int params_stride, __global const float4 *wo,
                             int wo_stride, __global const float4 *wi, __global float *out) {
    int i = get_global_id(0);
    if (i >= n) return;
    Component c = probe_component(lobe, params + (size_t)i * params_stride);
    out[i] = component_pdf(c, wo[(size_t)i * wo_stride].xyz, wi[i].xyz);
}

/* wi_out[i] = (wi, delta), weight_out[i] = (weight, pdf) of one sample */
__kernel void bsdf_sample_probe(int n, int lobe, __global const BsdfProbeParams *params, int params_stride, __global const float4 *wo,
                                int wo_stride, __global const float4 *u, __global float4 *wi_out, __global float4 *weight_out) {
    int i = get_global_id(0);
    if (i >= n) return;
    Component c = probe_component(lobe, params + (size_t)i * params_stride);
    float4 ui = u[i];
    BsdfSample s = component_sample(c, wo[(size_t)i * wo_stride].xyz, ui.x, (float2)(ui.y, ui.z));
    wi_out[i] = (float4)(s.wi, (float)s.delta);
    weight_out[i] = (float4)(s.weight, s.pdf);
}

/* The shading frame of normals[i]: out rows 3i..3i+2 = t, b, n; in_frame[i] = to_local(frame, v[i]),
 * back[i] = to_world(frame, in_frame[i]). */
__kernel void frame_probe(int n, __global const float4 *normals, __global const float4 *v, __global float4 *out,
                          __global float4 *in_frame, __global float4 *back) {
    int i = get_global_id(0);
    if (i >= n) return;
    Frame f = make_frame(normals[i].xyz);
    out[3 * i] = (float4)(f.t, 0.0f);
    out[3 * i + 1] = (float4)(f.b, 0.0f);
    out[3 * i + 2] = (float4)(f.n, 0.0f);
    float3 l = to_local(f, v[i].xyz);
    in_frame[i] = (float4)(l, 0.0f);
    back[i] = (float4)(to_world(f, l), 0.0f);
}
