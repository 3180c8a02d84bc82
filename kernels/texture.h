/* Image textures (clrender/scene/textures.py packs them): texture coordinates interpolated at a hit, wrap
 * modes, bilinear (or nearest) lookups in the one float4 texel buffer, and a material's parameters with its
 * textures and vertex colours applied.  No mip-maps: a lookup reads the 4 texels around the point (minified
 * textures alias, as a renderer without filtering does; many samples a pixel average it away).
 *
 * Records (clrender/layout.py): VertexAttributes (per primitive id), Texture, Material.  Texel (0, 0) is the
 * image's top-left and texture coordinate (0, 0) its top-left corner (glTF's convention): texel (i, j)
 * covers u in [i, i + 1) / width, v in [j, j + 1) / height. */
#ifndef CLRENDER_TEXTURE_H
#define CLRENDER_TEXTURE_H

#include "common.h"

/* What texture lookups read. */
typedef struct {
    __global const VertexAttributes *attributes; /* per primitive id */
    __global const Texture *textures;
    __global const float4 *texels;
#if INSTANCED
    __global const float *tangent_to_world; /* a hit on an instance: its object_to_world (3x4), whose tangents are in object space; else 0 */
#endif
} TextureView;

INLINE TextureView texture_view(__global const VertexAttributes *attributes, __global const Texture *textures,
                                __global const float4 *texels) {
    TextureView t;
    t.attributes = attributes; t.textures = textures; t.texels = texels;
#if INSTANCED
    t.tangent_to_world = 0;
#endif
    return t;
}

/* Whether any of the material's slots holds a texture (untextured materials skip every lookup). */
INLINE bool material_textured(const Material *m) {
    for (int k = 0; k < TEXTURE_SLOTS; ++k)
        if (m->textures[k] >= 0) return true;
    return false;
}

/* Texel index i (any integer) along a side of n texels under a glTF wrap mode. */
INLINE int wrap_index(int i, int n, int mode) {
    if (mode == WRAP_CLAMP_TO_EDGE) return clamp(i, 0, n - 1);
    if (mode == WRAP_MIRRORED_REPEAT) {
        int m = i % (2 * n);
        if (m < 0) m += 2 * n;
        return m < n ? m : 2 * n - 1 - m;
    }
    int m = i % n;
    return m < 0 ? m + n : m;
}

/* A coordinate brought near [0, 1] without changing what it addresses (huge ones would overflow int). */
INLINE float wrap_coord(float x, int mode) {
    if (!(x == x)) return 0.0f; /* NaN */
    if (mode == WRAP_CLAMP_TO_EDGE) return clamp(x, -1.0f, 2.0f);
    float period = mode == WRAP_MIRRORED_REPEAT ? 2.0f : 1.0f;
    return x - period * floor(x / period);
}

INLINE float4 texel_at(TextureView tv, __global const Texture *t, int i, int j) {
    i = wrap_index(i, t->width, t->wrap_s);
    j = wrap_index(j, t->height, t->wrap_t);
    return tv.texels[t->offset + j * t->width + i];
}

/* Texture `index` at coordinates uv: bilinear between the four nearest texel centres, or the nearest texel. */
INLINE float4 texture_lookup(TextureView tv, int index, float2 uv) {
    __global const Texture *t = tv.textures + index;
    float x = wrap_coord(uv.x, t->wrap_s) * (float)t->width, y = wrap_coord(uv.y, t->wrap_t) * (float)t->height;
    if (t->nearest) return texel_at(tv, t, (int)floor(x), (int)floor(y));
    x -= 0.5f; y -= 0.5f;
    float fx = floor(x), fy = floor(y);
    int i = (int)fx, j = (int)fy;
    float ax = x - fx, ay = y - fy;
    float4 top = (1.0f - ax) * texel_at(tv, t, i, j) + ax * texel_at(tv, t, i + 1, j);
    float4 bottom = (1.0f - ax) * texel_at(tv, t, i, j + 1) + ax * texel_at(tv, t, i + 1, j + 1);
    return (1.0f - ay) * top + ay * bottom;
}

/* UV set `set` (0 or 1) of primitive `prim` at barycentrics (u, v) of v1 and v2. */
INLINE float2 hit_uv(TextureView tv, int prim, int set, float u, float v) {
    __global const float *uv = set ? &tv.attributes[prim].uv1[0][0] : &tv.attributes[prim].uv[0][0];
    return (1.0f - u - v) * vload2(0, uv) + u * vload2(1, uv) + v * vload2(2, uv);
}

INLINE float3 hit_colour(TextureView tv, int prim, float u, float v) {
    __global const float *c = &tv.attributes[prim].colour[0][0];
    return (1.0f - u - v) * vload3(0, c) + u * vload3(1, c) + v * vload3(2, c);
}

/* The texel of the material's slot at the hit, through its texCoord and KHR_texture_transform. */
INLINE float4 slot_texel(TextureView tv, const Material *m, int slot, int prim, float u, float v) {
    float2 uv = hit_uv(tv, prim, m->tex_coord[slot], u, v);
    const float *x = m->tex_transform[slot];
    float2 t = (float2)(x[0] * uv.x + x[1] * uv.y + x[2], x[3] * uv.x + x[4] * uv.y + x[5]);
    return texture_lookup(tv, m->textures[slot], t);
}

/* slot_texel of a material read where it lies in the Material buffer (the path tracer keeps no private copy of the
 * 256-byte record: kernels/path.cl's Shading). */
INLINE float4 material_texel(TextureView tv, __global const Material *m, int slot, int prim, float u, float v) {
    float2 uv = hit_uv(tv, prim, m->tex_coord[slot], u, v);
    __global const float *x = m->tex_transform[slot];
    float2 t = (float2)(x[0] * uv.x + x[1] * uv.y + x[2], x[3] * uv.x + x[4] * uv.y + x[5]);
    return texture_lookup(tv, m->textures[slot], t);
}

/* The material at a hit (prim, u, v) with its textures and the object's vertex colours applied: kd and
 * base_color times the colour texture and vertex colour, metallic times B and roughness times G of the
 * metallic-roughness texture, emission times the emissive texture. */
INLINE void apply_textures(TextureView tv, Material *m, int prim, float u, float v, bool vertex_colours) {
    float3 colour = vertex_colours ? hit_colour(tv, prim, u, v) : (float3)(1.0f);
    if (m->textures[TEXTURE_BASE_COLOR] >= 0) colour *= slot_texel(tv, m, TEXTURE_BASE_COLOR, prim, u, v).xyz;
    vstore3(vload3(0, m->kd) * colour, 0, m->kd);
    vstore3(vload3(0, m->base_color) * colour, 0, m->base_color);
    if (m->textures[TEXTURE_METALLIC_ROUGHNESS] >= 0) {
        float4 mr = slot_texel(tv, m, TEXTURE_METALLIC_ROUGHNESS, prim, u, v);
        m->metallic *= mr.z;
        m->roughness *= mr.y;
    }
    if (m->textures[TEXTURE_EMISSIVE] >= 0)
        vstore3(vload3(0, m->emission) * slot_texel(tv, m, TEXTURE_EMISSIVE, prim, u, v).xyz, 0, m->emission);
}

/* The shading normal tilted by a normal map's texel (glTF's normalTexture; its rgb in `texel`, x and y scaled by `scale`)
 * at the hit: n_side and n_geo_side face the ray (direction d), `front` says whether that is the primitive's front.  The
 * tangent frame is the interpolated tangent made orthogonal to the front-side normal n and the bitangent w n x t; the
 * texel's 2 rgb - 1 (x, y scaled) is taken in it.  A normal that ends up facing away from the ray, or a triangle without
 * tangents (no UVs), keeps n_side. */
INLINE float3 normal_from_texel(TextureView tv, float3 texel, float scale, int prim, float u, float v, float3 n_side, bool front,
                                float3 d) {
    __global const float *tg = &tv.attributes[prim].tangent[0][0];
    float4 t4 = (1.0f - u - v) * vload4(0, tg) + u * vload4(1, tg) + v * vload4(2, tg);
#if INSTANCED
    __global const float *w = tv.tangent_to_world; /* tangents go to world space as vectors, by object_to_world */
    if (w) t4.xyz = (float3)(w[0] * t4.x + w[1] * t4.y + w[2] * t4.z, w[4] * t4.x + w[5] * t4.y + w[6] * t4.z,
                             w[8] * t4.x + w[9] * t4.y + w[10] * t4.z);
#endif
    float3 n = front ? n_side : -n_side;
    float3 t = t4.xyz - n * dot3(n, t4.xyz);
    if (!(dot3(t, t) > 1e-12f)) return n_side;
    t = unit(t);
    float3 b = (t4.w < 0.0f ? -1.0f : 1.0f) * cross3(n, t);
    float3 c = 2.0f * texel - 1.0f;
    float3 mapped = unit(scale * (c.x * t + c.y * b) + c.z * n);
    mapped = front ? mapped : -mapped;
    return dot3(mapped, d) < 0.0f ? mapped : n_side;
}

/* The shading normal tilted by the material's normal map at the hit (normal_from_texel). */
INLINE float3 normal_mapped(TextureView tv, const Material *m, int prim, float u, float v, float3 n_side, bool front, float3 d) {
    float3 texel = slot_texel(tv, m, TEXTURE_NORMAL, prim, u, v).xyz;
    return normal_from_texel(tv, texel, m->normal_scale, prim, u, v, n_side, front, d);
}

/* glTF's ambient occlusion at the hit: 1 + strength (R - 1), 1 without an occlusion texture. */
INLINE float material_occlusion(TextureView tv, const Material *m, int prim, float u, float v) {
    if (m->textures[TEXTURE_OCCLUSION] < 0) return 1.0f;
    return 1.0f + m->occlusion_strength * (slot_texel(tv, m, TEXTURE_OCCLUSION, prim, u, v).x - 1.0f);
}

#endif
