/* Test-only kernels: the BSDF lobes of bsdf.h over batches, for tests/test_bsdf*.py through
 * clrender/trace/bsdf.py, through the dispatch the path tracer calls (component_eval, component_pdf,
 * component_sample): a Component of each record's lobe code and parameters.  Built at LANES 1 (one item a work-item,
 * as the path tracer runs the lobes) or LANES 8 or 16 (that many items a work-item, one in each lane), which must
 * give the same bits.
 *   params  BsdfProbeParams records (clrender/layout.py); record i * params_stride
 *   wo, wi  float4 per item (xyz, unused); wo read at i * wo_stride (stride 0: one shared by all)
 *   u       float4 per item: (u1, u2.x, u2.y, unused)
 * Build with clrender.trace.bsdf.bsdf_defines() (common.h's traversal knobs). */
#define DET_MATH 1 /* as path.cl: the lobes the path tracer runs */
#include "mathf.h"
#include "common.h"
#include "lanes.h"
#include "rng.h"
#include "bsdf.h"

#define PROBE_FIELD(f) ((int)(__builtin_offsetof(BsdfProbeParams, f) / 4)) /* a record's field, in floats */
#define PROBE_FLOATS ((int)(sizeof(BsdfProbeParams) / 4))

/* the work-item's items, base .. base + LANES - 1; lanes past the last item repeat it and are not stored */
INLINE LI probe_items(int base, int n) { return min(base + AS_LI(LANE_IDS_L), n - 1); }

INLINE Component probe_component(__global const BsdfProbeParams *records, LI record) {
    __global const float *r = (__global const float *)records;
    LI at = record * PROBE_FLOATS;
    Component c;
    c.lobe = CONVERT_I(gather(r, at + PROBE_FIELD(lobe)));
    BsdfParams p;
    p.colour = gather3(r, at + PROBE_FIELD(colour));
    p.alpha = gather(r, at + PROBE_FIELD(alpha));
    p.eta = gather(r, at + PROBE_FIELD(eta));
    p.metallic = gather(r, at + PROBE_FIELD(metallic));
    p.smith = CONVERT_I(gather(r, at + PROBE_FIELD(smith)));
    p.nonlinear = gather(r, at + PROBE_FIELD(nonlinear)) != 0.0f;
    p.eta3 = gather3(r, at + PROBE_FIELD(eta3));
    p.k3 = gather3(r, at + PROBE_FIELD(k3));
    p.tint = gather3(r, at + PROBE_FIELD(tint));
    p.transmit_tint = gather3(r, at + PROBE_FIELD(transmit_tint));
    p.coat_weight = gather(r, at + PROBE_FIELD(coat_weight));
    p.coat_internal = gather(r, at + PROBE_FIELD(coat_internal));
    p.coat_tables = r;
    p.coat_table = at + PROBE_FIELD(coat_transmittance);
    p.specular_prob = gather(r, at + PROBE_FIELD(specular_prob));
    c.bsdf = p;
    return c;
}

/* float4 row i's xyz */
INLINE V3 row3(__global const float4 *rows, LI i) { return gather3((__global const float *)rows, 4 * i); }

/* out[item * stride + at] = (v, w) for the work-item's items below n */
#define PUT_XYZW(out, stride, at, v, w)                                         \
    do {                                                                        \
        V3 v_ = (v);                                                            \
        STORE_FLOAT4((out) + (at), stride, base, n, v_.x, v_.y, v_.z, (LF)(w));   \
    } while (0)

/* out[i] = (eval(wo, wi), 0) of record i's lobe: f * |cos theta_i| */
__kernel void bsdf_eval_probe(int n, __global const BsdfProbeParams *params, int params_stride, __global const float4 *wo,
                              int wo_stride, __global const float4 *wi, __global float4 *out) {
    int base = get_global_id(0) * LANES;
    if (base >= n) return;
    LI i = probe_items(base, n);
    Component c = probe_component(params, i * params_stride);
    PUT_XYZW(out, 1, 0, component_eval(c, row3(wo, i * wo_stride), row3(wi, i)), 0.0f);
}

/* out[i] = pdf(wo, wi), solid angle */
__kernel void bsdf_pdf_probe(int n, __global const BsdfProbeParams *params, int params_stride, __global const float4 *wo,
                             int wo_stride, __global const float4 *wi, __global float *out) {
    int base = get_global_id(0) * LANES;
    if (base >= n) return;
    LI i = probe_items(base, n);
    Component c = probe_component(params, i * params_stride);
    STORE_LANES(float, out, 1, base, n, component_pdf(c, row3(wo, i * wo_stride), row3(wi, i)));
}

/* wi_out[i] = (wi, delta), weight_out[i] = (weight, pdf) of one sample */
__kernel void bsdf_sample_probe(int n, __global const BsdfProbeParams *params, int params_stride, __global const float4 *wo,
                                int wo_stride, __global const float4 *u, __global float4 *wi_out, __global float4 *weight_out) {
    int base = get_global_id(0) * LANES;
    if (base >= n) return;
    LI i = probe_items(base, n);
    Component c = probe_component(params, i * params_stride);
    V3 ui = row3(u, i);
    BsdfSample s = component_sample(c, row3(wo, i * wo_stride), ui.x, v2(ui.y, ui.z));
    PUT_XYZW(wi_out, 1, 0, s.wi, s.delta ? (LF)(1.0f) : (LF)(0.0f));
    PUT_XYZW(weight_out, 1, 0, s.weight, s.pdf);
}

/* The shading frame of normals[i]: out rows 3i..3i+2 = t, b, n; in_frame[i] = to_local(frame, v[i]),
 * back[i] = to_world(frame, in_frame[i]). */
__kernel void frame_probe(int n, __global const float4 *normals, __global const float4 *v, __global float4 *out,
                          __global float4 *in_frame, __global float4 *back) {
    int base = get_global_id(0) * LANES;
    if (base >= n) return;
    LI i = probe_items(base, n);
    Frame f = make_frame(row3(normals, i));
    PUT_XYZW(out, 3, 0, f.t, 0.0f);
    PUT_XYZW(out, 3, 1, f.b, 0.0f);
    PUT_XYZW(out, 3, 2, f.n, 0.0f);
    V3 l = to_local(f, row3(v, i));
    PUT_XYZW(in_frame, 1, 0, l, 0.0f);
    PUT_XYZW(back, 1, 0, to_world(f, l), 0.0f);
}
