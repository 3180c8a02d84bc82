/* Test-only kernels: envmap.h's sampler and lookup over batches, for tests through clrender/trace/envmap.py
 * (EnvProbe).  Build with clrender.trace.tracer.trace_defines() (common.h's traversal knobs). */
#define DET_MATH 1 /* as path.cl: the lookups the path tracer runs */
#include "mathf.h"
#include "common.h"
#include "envmap.h"

/* out[i] = (direction, solid-angle density) of the map's sample for uniforms u[i] */
__kernel void env_sample_probe(int n, __global const float2 *u, EnvMap env_map, __global const float4 *env_texels,
                               __global const float *env_marginal, __global const float *env_conditional, __global const int *env_guides,
                               __global float4 *out) {
    int i = get_global_id(0);
    if (i >= n) return;
    EnvView e = env_view(env_map, env_texels, env_marginal, env_conditional, env_guides);
    float3 radiance;
    float pdf;
    float3 d = env_sample(&e, u[i], &radiance, &pdf);
    out[i] = (float4)(d, pdf);
}

/* out[i] = (radiance, solid-angle density) towards directions[i].xyz (unit, world) */
__kernel void env_eval_probe(int n, __global const float4 *directions, EnvMap env_map, __global const float4 *env_texels,
                             __global const float *env_marginal, __global const float *env_conditional, __global const int *env_guides,
                             __global float4 *out) {
    int i = get_global_id(0);
    if (i >= n) return;
    EnvView e = env_view(env_map, env_texels, env_marginal, env_conditional, env_guides);
    float pdf;
    float3 radiance = env_eval(&e, directions[i].xyz, &pdf);
    out[i] = (float4)(radiance, pdf);
}
