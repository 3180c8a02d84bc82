/* The surface pipeline both integrators shade through (pbrt-v4's SurfaceInteraction::GetBSDF): a hit becomes a
 * surface point (surface_at: the point, its error bound, the normals on the ray's side, UVs, the tangent frame), and
 * the surface point a material point (material_at: the Material record's parameters after the texture slots, the
 * vertex colours, the normal map, alpha and occlusion).  shade.h's Whitted integrator and path.cl's path tracer call
 * these two and nothing else computes them.  Records are read where they lie in their __global buffers: no private
 * copy of the 256-byte Material (a copy per hit cost the path tracer 4-5 % of its CPU time: docs/benchmarks.md).
 *
 * What each texture slot scales is clrender/layout.py's TEXTURE_SLOT_TABLE; material_at is its one kernel rule.
 * Records (clrender/layout.py): ObjectRecord, Material, VertexNormals, VertexAttributes, Texture. */
#ifndef CLRENDER_SURFACE_H
#define CLRENDER_SURFACE_H

#include "common.h"
#include "intersect.h"
#include "texture.h"

/* A point met by a ray (direction d), its normals turned to face the ray. */
typedef struct {
    float3 p, p_err;   /* the point and its float32 error bound (offset_origin) */
    float3 n_geo;      /* unit geometric normal, on the side the ray came from */
    float3 n_shade;    /* unit shading normal, on the same side (material_at tilts it by a normal map) */
    float3 d;          /* the ray's direction */
    bool front;        /* the ray met the primitive's front (its normal's side: outward, or the winding's) */
    bool sphere;       /* an analytic sphere (no vertex normals, UVs or tangents) */
    bool smooth;       /* the object interpolates vertex normals */
    bool vertex_colours; /* the object's vertex colours scale its colour */
    int object, material, prim; /* the object, its Material index, the primitive's VertexAttributes / VertexNormals index */
    float u, v;        /* barycentrics of the primitive's v1 and v2 */
    float2 uv[2];      /* texture coordinates, sets 0 and 1 (a textured material only; else 0) */
    bool has_frame;    /* a normal-mapped material with a usable tangent: t and b below */
    float3 tangent, bitangent; /* unit tangent, orthogonal to the front-side shading normal, and w n x t */
} Surface;

/* A textured material's texture coordinates at hit (prim, u, v), both sets (hit_uv). */
INLINE void surface_uvs(TextureView tv, int prim, float u, float v, float2 *uv) {
    uv[0] = hit_uv(tv, prim, 0, u, v);
    uv[1] = hit_uv(tv, prim, 1, u, v);
}

/* A smooth triangle's normal at hit h, interpolated from its vertex normals (an instance's turned to world space). */
INLINE float3 smooth_normal(const Geometry *g, __global const VertexNormals *normals, Hit h) {
    __global const float *vn = &normals[hit_data(g, h)].normal[0][0];
    float3 n0 = vload3(0, vn), n1 = vload3(1, vn), n2 = vload3(2, vn);
#if INSTANCED
    if (h.instance >= 0) vertex_normals_to_world(g->instances + h.instance, &n0, &n1, &n2);
#endif
    return unit((1.0f - h.u - h.v) * n0 + h.u * n1 + h.v * n2);
}

/* The tangent frame of a normal map at f (glTF): the interpolated tangent (an instance's turned to world space as a
 * vector, by object_to_world) made orthogonal to the front-side shading normal n, and the bitangent w n x t.  A
 * triangle without tangents (no UVs) has none. */
INLINE void tangent_frame(const Geometry *g, TextureView tv, Hit h, Surface *f) {
    __global const float *tg = &tv.attributes[f->prim].tangent[0][0];
    float4 t4 = (1.0f - f->u - f->v) * vload4(0, tg) + f->u * vload4(1, tg) + f->v * vload4(2, tg);
#if INSTANCED
    if (h.instance >= 0) {
        __global const float *w = &g->instances[h.instance].object_to_world[0][0];
        t4.xyz = (float3)(w[0] * t4.x + w[1] * t4.y + w[2] * t4.z, w[4] * t4.x + w[5] * t4.y + w[6] * t4.z,
                          w[8] * t4.x + w[9] * t4.y + w[10] * t4.z);
    }
#endif
    float3 n = f->front ? f->n_shade : -f->n_shade;
    float3 t = t4.xyz - n * dot3(n, t4.xyz);
    f->has_frame = dot3(t, t) > 1e-12f;
    if (!f->has_frame) return;
    f->tangent = unit(t);
    f->bitangent = (t4.w < 0.0f ? -1.0f : 1.0f) * cross3(n, f->tangent);
}

/* The surface point of hit h of ray (o, d). */
INLINE Surface surface_at(const Geometry *g, __global const VertexNormals *normals, TextureView tv, Hit h, float3 o, float3 d) {
    Surface f;
    f.object = hit_object(g, h);
    ObjectRecord obj = g->objects[f.object];
    f.material = obj.material;
    f.smooth = obj.smooth;
    f.vertex_colours = obj.vertex_colours;
    f.prim = hit_data(g, h);
    f.u = h.u; f.v = h.v;
    f.d = d;
    f.p = hit_surface(g, h, o, d, &f.p_err, &f.n_geo, &f.sphere);
    f.n_shade = f.n_geo;
    if (obj.smooth && !f.sphere) f.n_shade = smooth_normal(g, normals, h);
    f.front = dot3(d, f.n_geo) < 0.0f;
    if (!f.front) { f.n_geo = -f.n_geo; f.n_shade = -f.n_shade; }
    if (dot3(f.n_shade, d) >= 0.0f) f.n_shade = f.n_geo; /* an interpolated normal facing away: flat */
    f.uv[0] = f.uv[1] = (float2)(0.0f);
    f.has_frame = false;
    __global const Material *m = &tv.materials[f.material];
    if (material_textured(tv, f.material)) surface_uvs(tv, f.prim, f.u, f.v, f.uv);
    if (m->textures[TEXTURE_NORMAL] >= 0) tangent_frame(g, tv, h, &f);
    return f;
}

/* What shading reads of a material at a surface point: the record's parameters with the texture slots
 * (layout.TEXTURE_SLOT_TABLE) and the vertex colours applied; `g` is the record, for what no slot changes. */
typedef struct {
    float3 kd, ks, base_color, emission;
    float shininess, mirror, transparency, ior, metallic, roughness, transmission;
    float alpha;     /* coverage: the factor times the base colour texture's alpha (kernels/alpha.h decides what it does) */
    float occlusion; /* glTF's ambient occlusion: 1 + strength (R - 1), 1 without the texture */
    int model;       /* a MATERIAL_MODELS code */
    __global const Material *g;
} MaterialPoint;

/* Emitted radiance of material mi at texture coordinates uv (both sets): its emission times the emissive slot. */
INLINE float3 emission_of(TextureView tv, int mi, const float2 *uv) {
    __global const Material *g = &tv.materials[mi];
    float3 le = vload3(0, g->emission);
    if (g->textures[TEXTURE_EMISSIVE] >= 0) le *= slot_texel(tv, mi, TEXTURE_EMISSIVE, uv).xyz;
    return le;
}

/* Coverage of material mi at hit (prim, u, v): its alpha factor times the base colour texture's alpha (material_at's
 * rule, for kernels/alpha.h, which reads it before a hit is shaded). */
INLINE float coverage_at(TextureView tv, int mi, int prim, float u, float v) {
    __global const Material *g = &tv.materials[mi];
    float alpha = g->alpha;
    if (g->textures[TEXTURE_BASE_COLOR] >= 0) {
        float2 uv[2];
        surface_uvs(tv, prim, u, v, uv);
        alpha *= slot_texel(tv, mi, TEXTURE_BASE_COLOR, uv).w;
    }
    return alpha;
}

/* The shading normal tilted by the normal map's texel (glTF's normalTexture, x and y scaled by normal_scale): the
 * texel's 2 rgb - 1 taken in f's tangent frame.  A normal that ends up facing away from the ray keeps n_shade. */
INLINE void normal_map(TextureView tv, __global const Material *g, Surface *f) {
    if (!f->has_frame) return;
    float3 n = f->front ? f->n_shade : -f->n_shade;
    float3 c = 2.0f * slot_texel(tv, f->material, TEXTURE_NORMAL, f->uv).xyz - 1.0f;
    float3 mapped = unit(g->normal_scale * (c.x * f->tangent + c.y * f->bitangent) + c.z * n);
    mapped = f->front ? mapped : -mapped;
    if (dot3(mapped, f->d) < 0.0f) f->n_shade = mapped;
}

/* The material at surface point f, every texture slot applied (layout.TEXTURE_SLOT_TABLE): kd, base_color and
 * alpha times the base colour texture's rgb and a (and kd, base_color times the vertex colour), metallic times B
 * and roughness times G of the metallic-roughness texture, emission times the emissive texture, occlusion from
 * the occlusion texture's R, and f's shading normal tilted by the normal texture. */
INLINE MaterialPoint material_at(TextureView tv, __global const Material *materials, Surface *f) {
    __global const Material *g = &materials[f->material];
    MaterialPoint m;
    m.g = g;
    m.kd = vload3(0, g->kd); m.ks = vload3(0, g->ks);
    m.base_color = vload3(0, g->base_color);
    m.shininess = g->shininess; m.mirror = g->mirror; m.transparency = g->transparency; m.ior = g->ior;
    m.metallic = g->metallic; m.roughness = g->roughness; m.transmission = g->transmission;
    m.model = g->model;
    m.alpha = g->alpha;
    if (f->vertex_colours || g->textures[TEXTURE_BASE_COLOR] >= 0) {
        float3 colour = f->vertex_colours ? hit_colour(tv, f->prim, f->u, f->v) : (float3)(1.0f);
        if (g->textures[TEXTURE_BASE_COLOR] >= 0) {
            float4 texel = slot_texel(tv, f->material, TEXTURE_BASE_COLOR, f->uv);
            colour *= texel.xyz;
            m.alpha *= texel.w;
        }
        m.kd *= colour;
        m.base_color *= colour;
    }
    if (g->textures[TEXTURE_METALLIC_ROUGHNESS] >= 0) {
        float4 mr = slot_texel(tv, f->material, TEXTURE_METALLIC_ROUGHNESS, f->uv);
        m.metallic *= mr.z;
        m.roughness *= mr.y;
    }
    m.emission = emission_of(tv, f->material, f->uv);
    m.occlusion = 1.0f;
    if (g->textures[TEXTURE_OCCLUSION] >= 0)
        m.occlusion = 1.0f + g->occlusion_strength * (slot_texel(tv, f->material, TEXTURE_OCCLUSION, f->uv).x - 1.0f);
    normal_map(tv, g, f);
    return m;
}

#endif
