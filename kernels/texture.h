/* Image textures (clrender/scene/textures.py packs them): texture coordinates interpolated at a hit, wrap
 * modes, bilinear (or nearest) lookups in the one float4 texel buffer, and a material's parameters with its
 * textures' texels.  No mip-maps: a lookup reads the 4 texels around the point (minified
 * textures alias, as a renderer without filtering does; many samples a pixel average it away).  What a material
 * makes of its texels is kernels/surface.h's material_at.
 *
 * Records (clrender/layout.py): VertexAttributes (per primitive id), Texture, Material.  Texel (0, 0) is the
 * image's top-left and texture coordinate (0, 0) its top-left corner (glTF's convention): texel (i, j)
 * covers u in [i, i + 1) / width, v in [j, j + 1) / height. */
#ifndef CLRENDER_TEXTURE_H
#define CLRENDER_TEXTURE_H

#include "common.h"

/* What material and texture lookups read. */
typedef struct {
    __global const VertexAttributes *attributes; /* per primitive id */
    __global const Texture *textures;
    __global const Material *materials;          /* by ObjectRecord.material */
    __global const float4 *texels;
} TextureView;

INLINE TextureView texture_view(__global const VertexAttributes *attributes, __global const Texture *textures,
                                __global const Material *materials, __global const float4 *texels) {
    TextureView t;
    t.attributes = attributes; t.textures = textures; t.materials = materials; t.texels = texels;
    return t;
}

/* Whether any of the material's slots holds a texture (untextured materials skip every lookup). */
INLINE bool material_textured(__global const Material *m) {
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

/* The texel of material m's texture `slot` at texture coordinates uv (sets 0 and 1: kernels/surface.h), through the
 * slot's texCoord and KHR_texture_transform. */
INLINE float4 slot_texel(TextureView tv, __global const Material *m, int slot, const float2 *uv) {
    float2 st = m->tex_coord[slot] ? uv[1] : uv[0];
    __global const float *x = m->tex_transform[slot];
    float2 t = (float2)(x[0] * st.x + x[1] * st.y + x[2], x[3] * st.x + x[4] * st.y + x[5]);
    return texture_lookup(tv, m->textures[slot], t);
}

#endif
