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

/* A point met by a ray (direction d), its normals turned to face the ray: a lane's (kernels/lanes.h; masks for flags). */
typedef struct {
    V3 p, p_err;       /* the point and its float32 error bound (offset_origin) */
    V3 n_geo;          /* unit geometric normal, on the side the ray came from */
    V3 n_shade;        /* unit shading normal, on the same side (material_at tilts it by a normal map) */
    V3 d;              /* the ray's direction */
    LI front;          /* the ray met the primitive's front (its normal's side: outward, or the winding's) */
    LI sphere;         /* an analytic sphere (no vertex normals, UVs or tangents) */
    LI smooth;         /* the object interpolates vertex normals */
    LI vertex_colours; /* the object's vertex colours scale its colour */
    LI object, material, prim; /* the object, its Material index, the primitive's VertexAttributes / VertexNormals index */
    LF u, v;           /* barycentrics of the primitive's v1 and v2 */
    V2 uv[2];          /* texture coordinates, sets 0 and 1 (a textured material only; else 0) */
    LI has_frame;      /* a normal-mapped material with a usable tangent: t and b below */
    V3 tangent, bitangent; /* unit tangent, orthogonal to the front-side shading normal, and w n x t */
} Surface;

/* a in the lanes of m, b in the others */
INLINE V2 pick2(LI m, V2 a, V2 b) {
#if LANES == 1
    return m ? a : b;
#else
    return v2(m ? a.x : b.x, m ? a.y : b.y);
#endif
}

/* A textured material's texture coordinates at hit (prim, u, v), both sets (hit_uv). */
INLINE void surface_uvs(TextureView tv, LI prim, LF u, LF v, V2 *uv) {
    uv[0] = hit_uv(tv, prim, 0, u, v);
    uv[1] = hit_uv(tv, prim, 1, u, v);
}

/* A smooth triangle's normal at hit h, interpolated from its vertex normals (an instance's turned to world space). */
INLINE V3 smooth_normal(const Geometry *g, __global const VertexNormals *normals, HitL h) {
    LI prim = hit_data(g, h);
#if LANES == 1
    __global const float *vn = &normals[prim].normal[0][0];
    float3 n0 = vload3(0, vn), n1 = vload3(1, vn), n2 = vload3(2, vn);
#else
    V3 n0 = FIELD3(normals, prim, normal[0]), n1 = FIELD3(normals, prim, normal[1]), n2 = FIELD3(normals, prim, normal[2]);
#endif
#if INSTANCED /* an instance's vertex normals each to world space before they are interpolated: as the flat scene's,
               * whose vertex normals scene.py placed one by one (the same shading under non-uniform scale) */
    LI on_instance = placed(h);
    if (ANY(on_instance)) {
        InstanceMap to_object = instance_map(g, instance_index(h), true);
        n0 = vpick(on_instance, normal_to_world(&to_object, n0), n0);
        n1 = vpick(on_instance, normal_to_world(&to_object, n1), n1);
        n2 = vpick(on_instance, normal_to_world(&to_object, n2), n2);
    }
#endif
    LF w = 1.0f - h.u - h.v;
    return vunit(v3(w * n0.x + h.u * n1.x + h.v * n2.x, w * n0.y + h.u * n1.y + h.v * n2.y, w * n0.z + h.u * n1.z + h.v * n2.z));
}

/* The tangent frame of a normal map at f (glTF), in the lanes of `mapped`: the interpolated tangent (an instance's
 * turned to world space as a vector, by object_to_world) made orthogonal to the front-side shading normal n, and the
 * bitangent w n x t.  A triangle without tangents (no UVs) has none. */
INLINE void tangent_frame(const Geometry *g, TextureView tv, HitL h, LI mapped, Surface *f) {
#if LANES == 1
    __global const float *tg = &tv.attributes[f->prim].tangent[0][0];
    float4 t4 = (1.0f - f->u - f->v) * vload4(0, tg) + f->u * vload4(1, tg) + f->v * vload4(2, tg);
#else
#define TANGENT(k) FIELD_F(tv.attributes, f->prim, tangent[(k) / 4][(k) % 4])
#define BLEND(c) ((1.0f - f->u - f->v) * TANGENT(c) + f->u * TANGENT(4 + c) + f->v * TANGENT(8 + c))
    V4 t4 = v4(BLEND(0), BLEND(1), BLEND(2), BLEND(3));
#undef BLEND
#undef TANGENT
#endif
    V3 n = vpick(f->front, f->n_shade, vneg(f->n_shade)), t3 = xyz_of(t4);
#if INSTANCED
    LI on_instance = placed(h);
    if (ANY(on_instance)) {
        InstanceMap to_world = instance_map(g, instance_index(h), false);
        t3 = vpick(on_instance, map_vector(&to_world, t3), t3);
    }
#endif
    LF k = vdot(n, t3);
    V3 t = v3(t3.x - n.x * k, t3.y - n.y * k, t3.z - n.z * k);
    f->has_frame = mapped & (vdot(t, t) > 1e-12f);
    if (!ANY(f->has_frame)) return;
    f->tangent = vpick(f->has_frame, vunit(t), f->tangent);
    f->bitangent = vpick(f->has_frame, vscale(t4.w < 0.0f ? (LF)(-1.0f) : (LF)(1.0f), vcross(n, f->tangent)), f->bitangent);
}

/* The surface point of hit h of ray (o, d). */
INLINE Surface surface_at(const Geometry *g, __global const VertexNormals *normals, TextureView tv, HitL h, V3 o, V3 d) {
    Surface f;
    f.object = hit_object(g, h);
    f.material = FIELD_I(g->objects, f.object, material);
    f.smooth = FIELD_I(g->objects, f.object, smooth) != 0;
    f.vertex_colours = FIELD_I(g->objects, f.object, vertex_colours) != 0;
    f.prim = hit_data(g, h);
    f.u = h.u; f.v = h.v;
    f.d = d;
    f.p = hit_surface(g, h, o, d, &f.p_err, &f.n_geo, &f.sphere);
    f.n_shade = f.n_geo;
    WHERE3(f.smooth & NOT(f.sphere), f.n_shade, smooth_normal(g, normals, h));
    f.front = vdot(d, f.n_geo) < 0.0f;
    f.n_geo = vpick(f.front, f.n_geo, vneg(f.n_geo));
    f.n_shade = vpick(f.front, f.n_shade, vneg(f.n_shade));
    f.n_shade = vpick(vdot(f.n_shade, d) >= 0.0f, f.n_geo, f.n_shade); /* an interpolated normal facing away: flat */
    f.uv[0] = f.uv[1] = v2(0.0f, 0.0f);
    f.has_frame = 0;
    f.tangent = f.bitangent = v3_all(0.0f);
    LI textured = material_textured(tv, f.material);
    if (ANY(textured)) {
        V2 uv[2];
        surface_uvs(tv, f.prim, f.u, f.v, uv);
        f.uv[0] = pick2(textured, uv[0], f.uv[0]);
        f.uv[1] = pick2(textured, uv[1], f.uv[1]);
    }
    LI mapped = FIELD_I(tv.materials, f.material, textures[TEXTURE_NORMAL]) >= 0;
    if (ANY(mapped)) tangent_frame(g, tv, h, mapped, &f);
    return f;
}

/* What shading reads of a material at a surface point: the record's parameters with the texture slots
 * (layout.TEXTURE_SLOT_TABLE) and the vertex colours applied; the record itself (materials[mi]) for what no slot
 * changes. */
typedef struct {
    V3 kd, ks, base_color, emission;
    LF shininess, mirror, transparency, ior, metallic, roughness, transmission;
    LF alpha;     /* coverage: the factor times the base colour texture's alpha (kernels/alpha.h decides what it does) */
    LF occlusion; /* glTF's ambient occlusion: 1 + strength (R - 1), 1 without the texture */
    LI model;     /* a MATERIAL_MODELS code */
    LI mi;        /* the Material record's index in materials */
    __global const Material *materials;
} MaterialPoint;

/* slot's texture in material mi: a mask */
INLINE LI has_texture(TextureView tv, LI mi, int slot) { return FIELD_I(tv.materials, mi, textures[slot]) >= 0; }

/* Emitted radiance of material mi at texture coordinates uv (both sets): its emission times the emissive slot. */
INLINE V3 emission_of(TextureView tv, LI mi, const V2 *uv) {
    V3 le = FIELD3(tv.materials, mi, emission);
    LI textured = has_texture(tv, mi, TEXTURE_EMISSIVE);
    WHERE3(textured, le, vmul(le, xyz_of(slot_texel(tv, mi, TEXTURE_EMISSIVE, uv))));
    return le;
}

/* Coverage of material mi at hit (prim, u, v): its alpha factor times the base colour texture's alpha (material_at's
 * rule, for kernels/alpha.h, which reads it before a hit is shaded). */
INLINE LF coverage_at(TextureView tv, LI mi, LI prim, LF u, LF v) {
    LF alpha = FIELD_F(tv.materials, mi, alpha);
    LI textured = has_texture(tv, mi, TEXTURE_BASE_COLOR);
    if (ANY(textured)) {
        V2 uv[2];
        surface_uvs(tv, prim, u, v, uv);
        alpha = textured ? alpha * slot_texel(tv, mi, TEXTURE_BASE_COLOR, uv).w : alpha;
    }
    return alpha;
}

/* The shading normal tilted by the normal map's texel (glTF's normalTexture, x and y scaled by normal_scale): the
 * texel's 2 rgb - 1 taken in f's tangent frame.  A normal that ends up facing away from the ray keeps n_shade. */
INLINE void normal_map(TextureView tv, Surface *f) {
    if (!ANY(f->has_frame)) return;
    V3 n = vpick(f->front, f->n_shade, vneg(f->n_shade)), texel = xyz_of(slot_texel(tv, f->material, TEXTURE_NORMAL, f->uv));
    V3 c = v3(2.0f * texel.x - 1.0f, 2.0f * texel.y - 1.0f, 2.0f * texel.z - 1.0f);
    LF s = FIELD_F(tv.materials, f->material, normal_scale);
    V3 t = f->tangent, b = f->bitangent;
    V3 mapped = vunit(v3(s * (c.x * t.x + c.y * b.x) + c.z * n.x, s * (c.x * t.y + c.y * b.y) + c.z * n.y, s * (c.x * t.z + c.y * b.z) + c.z * n.z));
    mapped = vpick(f->front, mapped, vneg(mapped));
    f->n_shade = vpick(f->has_frame & (vdot(mapped, f->d) < 0.0f), mapped, f->n_shade);
}

/* The material at surface point f, every texture slot applied (layout.TEXTURE_SLOT_TABLE): kd, base_color and
 * alpha times the base colour texture's rgb and a (and kd, base_color times the vertex colour), metallic times B
 * and roughness times G of the metallic-roughness texture, emission times the emissive texture, occlusion from
 * the occlusion texture's R, and f's shading normal tilted by the normal texture. */
INLINE MaterialPoint material_at(TextureView tv, __global const Material *materials, Surface *f) {
    LI mi = f->material;
    MaterialPoint m;
    m.mi = mi;
    m.materials = materials;
    m.kd = FIELD3(materials, mi, kd); m.ks = FIELD3(materials, mi, ks);
    m.base_color = FIELD3(materials, mi, base_color);
    m.shininess = FIELD_F(materials, mi, shininess); m.mirror = FIELD_F(materials, mi, mirror);
    m.transparency = FIELD_F(materials, mi, transparency); m.ior = FIELD_F(materials, mi, ior);
    m.metallic = FIELD_F(materials, mi, metallic); m.roughness = FIELD_F(materials, mi, roughness);
    m.transmission = FIELD_F(materials, mi, transmission);
    m.model = FIELD_I(materials, mi, model);
    m.alpha = FIELD_F(materials, mi, alpha);
    LI base_textured = has_texture(tv, mi, TEXTURE_BASE_COLOR), coloured = f->vertex_colours | base_textured;
    if (ANY(coloured)) {
        V3 colour = v3_all(1.0f);
        WHERE3(f->vertex_colours, colour, hit_colour(tv, f->prim, f->u, f->v));
        if (ANY(base_textured)) {
            V4 texel = slot_texel(tv, mi, TEXTURE_BASE_COLOR, f->uv);
            colour = vpick(base_textured, vmul(colour, xyz_of(texel)), colour);
            m.alpha = base_textured ? m.alpha * texel.w : m.alpha;
        }
        m.kd = vpick(coloured, vmul(m.kd, colour), m.kd);
        m.base_color = vpick(coloured, vmul(m.base_color, colour), m.base_color);
    }
    LI mr_textured = has_texture(tv, mi, TEXTURE_METALLIC_ROUGHNESS);
    if (ANY(mr_textured)) {
        V4 mr = slot_texel(tv, mi, TEXTURE_METALLIC_ROUGHNESS, f->uv);
        m.metallic = mr_textured ? m.metallic * mr.z : m.metallic;
        m.roughness = mr_textured ? m.roughness * mr.y : m.roughness;
    }
    m.emission = emission_of(tv, mi, f->uv);
    m.occlusion = 1.0f;
    LI occluded = has_texture(tv, mi, TEXTURE_OCCLUSION);
    WHERE(occluded, m.occlusion, 1.0f + FIELD_F(materials, mi, occlusion_strength) * (slot_texel(tv, mi, TEXTURE_OCCLUSION, f->uv).x - 1.0f));
    normal_map(tv, f);
    return m;
}

#endif
