/* Image textures (clrender/scene/textures.py packs them): texture coordinates interpolated at a hit, wrap
 * modes, bilinear (or nearest) lookups in the one float4 texel buffer, and a material's parameters with its
 * textures' texels.  No mip-maps: a lookup reads the 4 texels around the point (minified
 * textures alias, as a renderer without filtering does; many samples a pixel average it away).  What a material
 * makes of its texels is kernels/surface.h's material_at.
 *
 * Records (clrender/layout.py): VertexAttributes (per primitive id), Texture, Material.  Texel (0, 0) is the
 * image's top-left and texture coordinate (0, 0) its top-left corner (glTF's convention): texel (i, j)
 * covers u in [i, i + 1) / width, v in [j, j + 1) / height.  Written over kernels/lanes.h's lane type: a lane's
 * material, texture and primitive are lane indices into the records. */
#ifndef CLRENDER_TEXTURE_H
#define CLRENDER_TEXTURE_H

#include "common.h"
#include "lanes.h"

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

/* Whether any of material mi's slots holds a texture (untextured materials skip every lookup): a mask. */
INLINE LI material_textured(TextureView tv, LI mi) {
    LI textured = 0;
    for (int k = 0; k < TEXTURE_SLOTS; ++k) {
        textured |= FIELD_I(tv.materials, mi, textures[k]) >= 0;
        if (ALL(textured)) break;
    }
    return textured;
}

/* Texel index i (|i| < 2^24: wrap_coord's coordinates times the size) along a side of n texels under a glTF wrap mode. */
INLINE LI wrap_index(LI i, LI n, LI mode) {
    LI clamped = mode == WRAP_CLAMP_TO_EDGE, mirrored = mode == WRAP_MIRRORED_REPEAT, w = 0;
    WHERE(clamped, w, clamp(i, (LI)(0), n - 1));
    if (ANY(mirrored)) {
        LI m = mod_l(i, 2 * n);
        w = mirrored ? (m < n ? m : 2 * n - 1 - m) : w;
    }
    WHERE(NOT(clamped | mirrored), w, mod_l(i, n));
    return w;
}

/* A coordinate brought near [0, 1] without changing what it addresses (huge ones would overflow int). */
INLINE LF wrap_coord(LF x, LI mode) {
    LF period = mode == WRAP_MIRRORED_REPEAT ? (LF)(2.0f) : (LF)(1.0f);
    LF w = mode == WRAP_CLAMP_TO_EDGE ? clamp(x, -1.0f, 2.0f) : x - period * floor(x / period);
    return x == x ? w : (LF)(0.0f); /* NaN: 0 */
}

/* texel (i, j) of texture t, each index wrapped */
INLINE V4 texel_at(TextureView tv, LI t, LI i, LI j) {
    LI width = FIELD_I(tv.textures, t, width);
    i = wrap_index(i, width, FIELD_I(tv.textures, t, wrap_s));
    j = wrap_index(j, FIELD_I(tv.textures, t, height), FIELD_I(tv.textures, t, wrap_t));
#if LANES == 1
    return tv.texels[tv.textures[t].offset + j * width + i];
#else
    LI at = 4 * (FIELD_I(tv.textures, t, offset) + j * width + i);
    __global const float *texels = (__global const float *)tv.texels;
    return v4(gather(texels, at), gather(texels, at + 1), gather(texels, at + 2), gather(texels, at + 3));
#endif
}

/* (1 - a) p + a q, a texel's channels each */
INLINE V4 lerp4(LF a, V4 p, V4 q) {
#if LANES == 1
    return (1.0f - a) * p + a * q;
#else
    return v4((1.0f - a) * p.x + a * q.x, (1.0f - a) * p.y + a * q.y, (1.0f - a) * p.z + a * q.z, (1.0f - a) * p.w + a * q.w);
#endif
}

/* Texture `index` at coordinates uv: bilinear between the four nearest texel centres, or the nearest texel. */
INLINE V4 texture_lookup(TextureView tv, LI index, V2 uv) {
    LF x = wrap_coord(uv.x, FIELD_I(tv.textures, index, wrap_s)) * CONVERT_F(FIELD_I(tv.textures, index, width));
    LF y = wrap_coord(uv.y, FIELD_I(tv.textures, index, wrap_t)) * CONVERT_F(FIELD_I(tv.textures, index, height));
    LI nearest = FIELD_I(tv.textures, index, nearest) != 0;
    V4 texel = v4(0.0f, 0.0f, 0.0f, 0.0f);
    if (ANY(nearest)) texel = texel_at(tv, index, CONVERT_I(floor(x)), CONVERT_I(floor(y)));
    if (ANY(NOT(nearest))) {
        x -= 0.5f; y -= 0.5f;
        LF fx = floor(x), fy = floor(y);
        LI i = CONVERT_I(fx), j = CONVERT_I(fy);
        LF ax = x - fx, ay = y - fy;
        V4 top = lerp4(ax, texel_at(tv, index, i, j), texel_at(tv, index, i + 1, j));
        V4 bottom = lerp4(ax, texel_at(tv, index, i, j + 1), texel_at(tv, index, i + 1, j + 1));
        V4 bilinear = lerp4(ay, top, bottom);
#if LANES == 1
        texel = bilinear;
#else
        texel = v4(nearest ? texel.x : bilinear.x, nearest ? texel.y : bilinear.y, nearest ? texel.z : bilinear.z, nearest ? texel.w : bilinear.w);
#endif
    }
    return texel;
}

/* UV set `set` (0 or 1) of primitive `prim` at barycentrics (u, v) of v1 and v2. */
INLINE V2 hit_uv(TextureView tv, LI prim, int set, LF u, LF v) {
#if LANES == 1
    __global const float *uv = set ? &tv.attributes[prim].uv1[0][0] : &tv.attributes[prim].uv[0][0];
    return (1.0f - u - v) * vload2(0, uv) + u * vload2(1, uv) + v * vload2(2, uv);
#else
    __global const float *a = (__global const float *)tv.attributes;
    LI at = prim * (int)(sizeof(VertexAttributes) / 4) + (set ? (int)(__builtin_offsetof(VertexAttributes, uv1) / 4) : 0);
    LF w = 1.0f - u - v;
    return v2(w * gather(a, at) + u * gather(a, at + 2) + v * gather(a, at + 4), w * gather(a, at + 1) + u * gather(a, at + 3) + v * gather(a, at + 5));
#endif
}

INLINE V3 hit_colour(TextureView tv, LI prim, LF u, LF v) {
#if LANES == 1
    __global const float *c = &tv.attributes[prim].colour[0][0];
    return (1.0f - u - v) * vload3(0, c) + u * vload3(1, c) + v * vload3(2, c);
#else
    __global const float *a = (__global const float *)tv.attributes;
    LI at = prim * (int)(sizeof(VertexAttributes) / 4) + (int)(__builtin_offsetof(VertexAttributes, colour) / 4);
    LF w = 1.0f - u - v;
    return v3(w * gather(a, at) + u * gather(a, at + 3) + v * gather(a, at + 6), w * gather(a, at + 1) + u * gather(a, at + 4) + v * gather(a, at + 7),
              w * gather(a, at + 2) + u * gather(a, at + 5) + v * gather(a, at + 8));
#endif
}

/* The texel of material mi's texture `slot` at texture coordinates uv (sets 0 and 1: kernels/surface.h), through the
 * slot's texCoord and KHR_texture_transform.  Where the slot is empty, a texel of texture 0, to be discarded. */
INLINE V4 slot_texel(TextureView tv, LI mi, int slot, const V2 *uv) {
    LI second = FIELD_I(tv.materials, mi, tex_coord[slot]) != 0;
#if LANES == 1
    V2 st = second ? uv[1] : uv[0];
#else
    V2 st = v2(second ? uv[1].x : uv[0].x, second ? uv[1].y : uv[0].y);
#endif
#define TRANSFORM(k) FIELD_F(tv.materials, mi, tex_transform[slot][k])
    V2 t = v2(TRANSFORM(0) * st.x + TRANSFORM(1) * st.y + TRANSFORM(2), TRANSFORM(3) * st.x + TRANSFORM(4) * st.y + TRANSFORM(5));
#undef TRANSFORM
    /* a lane whose material has no texture in the slot reads texture 0, and its caller does not keep the texel */
    return texture_lookup(tv, max(FIELD_I(tv.materials, mi, textures[slot]), (LI)(0)), t);
}

#endif
