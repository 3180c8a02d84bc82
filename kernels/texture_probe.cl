/* Test-only kernel: kernels/texture.h's lookups over a batch, for tests/trace/test_texture_lanes.py.  Built at LANES 1
 * (one lookup a work-item, as the renderers run them) or 8 or 16 (that many a work-item, one in each lane), which give
 * the same bits.  Item i: material query[i].x, slot query[i].y, primitive query[i].z, barycentrics bary[i]; out[i]:
 * the slot's texel at the primitive's texture coordinates there (slot_texel), uv[i]: both UV sets (hit_uv),
 * colour[i]: the vertex colour (hit_colour) and whether the material has any texture (material_textured). */
#define DET_MATH 1
#include "mathf.h"
#include "common.h"
#include "lanes.h"
#include "texture.h"

/* out[item] = v for the work-item's items below n */
#define PUT4(out, v)                                            \
    do {                                                        \
        V4 v_ = (v);                                            \
        STORE_FLOAT4(out, 1, base, n, v_.x, v_.y, v_.z, v_.w);    \
    } while (0)

__kernel void texture_probe(int n, __global const int4 *query, __global const float2 *bary, __global const VertexAttributes *attributes,
                            __global const Texture *textures, __global const Material *materials, __global const float4 *texels,
                            __global float4 *out, __global float4 *uv_out, __global float4 *colour_out) {
    int base = get_global_id(0) * LANES;
    if (base >= n) return;
    LI item = min(base + AS_LI(LANE_IDS_L), n - 1);
    __global const int *q = (__global const int *)query;
    __global const float *b = (__global const float *)bary;
    LI mi = gather_i(q, 4 * item), prim = gather_i(q, 4 * item + 2);
    LF u = gather(b, 2 * item), v = gather(b, 2 * item + 1);
    TextureView tv = texture_view(attributes, textures, materials, texels);
    V2 uv[2] = {hit_uv(tv, prim, 0, u, v), hit_uv(tv, prim, 1, u, v)};
    /* the slot is uniform in a launch's kernels (a material's slots are separate code): each item's own, one pass a slot */
    LI slot = gather_i(q, 4 * item + 1);
    V4 texel = v4(0.0f, 0.0f, 0.0f, 0.0f);
    for (int k = 0; k < TEXTURE_SLOTS; ++k) {
        LI here = slot == k;
        if (!ANY(here)) continue;
        V4 t = slot_texel(tv, mi, k, uv);
#if LANES == 1
        texel = t;
#else
        texel = v4(here ? t.x : texel.x, here ? t.y : texel.y, here ? t.z : texel.z, here ? t.w : texel.w);
#endif
    }
    PUT4(out, texel);
    PUT4(uv_out, v4(uv[0].x, uv[0].y, uv[1].x, uv[1].y));
    V3 c = hit_colour(tv, prim, u, v);
    PUT4(colour_out, v4(c.x, c.y, c.z, material_textured(tv, mi) ? (LF)(1.0f) : (LF)(0.0f)));
}
