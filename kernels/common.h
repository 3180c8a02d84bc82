/* Shared definitions for the tracing kernels (OpenCL C 1.2, float32).
 *
 * Buffer records are declared in clrender/layout.py and reach the kernels as generated C structs, read
 * by field name; packed by clrender/trace/geometry.py, bvh.py, bvh_wide.py, tracer.py, materials.py,
 * lights.py and renderer.py:
 *   nodes     the BVH (Geometry.nodes, kernels/intersect.h).  BVH_WIDTH 2: BvhNode records, depth
 *             first; leaf: count > 0, slots [offset, offset+count); interior: count == 0, near
 *             child i+1, far child `offset`.  BVH_WIDTH 4 or 8: WideNode records, then LeafBlocks.
 *   prims     a PrimSlot per primitive slot, in BVH leaf order (a sphere's read as a SphereSlot):
 *             a triangle's vertices themselves, so two triangles that share an edge see
 *             bit-identical endpoints (watertight); `id`, the primitive's index in scene order.
 *   prim_object  int per primitive id: its object id.
 *   normals   VertexNormals per primitive id: a smooth triangle's vertex normals.
 *   objects   ObjectRecord per object: material index, smooth shading flag.
 *   materials Material records.
 *   lights    Light records (type, samples, intensity, falloff, position, direction, colour, edges).
 * The small per-scene records (instances, the top tree, objects, materials, textures) reach the kernels as regions
 * of one `tables` arena, the lights and environment as regions of the render kernels' `world` (REGION below). */
#ifndef CLRENDER_COMMON_H
#define CLRENDER_COMMON_H

/* checks clrender/layout.py's header (values and record structs) came with the build */
#include "layout.h"

/* The traversal's build knobs come from the host (clrender.trace.tracer.trace_defines), never from defaults here:
 * USE_BVH (0: test every primitive), MAX_DEPTH (longest mirror/refraction chain a kernel supports),
 * STACK_SIZE (BVH traversal stack, clrender.trace.knobs.TraceKnobs.stack_size; the builder keeps trees shallower),
 * BVH_WIDTH (2: binary nodes; 4 or 8: wide nodes, clrender/trace/bvh_wide.py), WIDE_STACK_SIZE. */
#if !defined(USE_BVH) || !defined(MAX_DEPTH) || !defined(STACK_SIZE) || !defined(BVH_WIDTH) || !defined(WIDE_STACK_SIZE)
#error "a traversal knob is missing: build trace.cl with clrender.trace.tracer.trace_defines()"
#endif
#define RAY_STACK (MAX_DEPTH + 2)
#if BVH_WIDTH != 2 && BVH_WIDTH != 4 && BVH_WIDTH != 8
#error "BVH_WIDTH must be 2, 4 or 8"
#endif
/* What the per-ray `visits` counter counts: nodes visited (leaves included; a wide node counts
 * once for its four boxes), or with -DCOUNT_PRIM_TESTS=1 the primitives tested. */
#if COUNT_PRIM_TESTS
#define COUNT_NODE(v)
#define COUNT_PRIMS(v, n) (*(v) += (uint)(n))
#else
#define COUNT_NODE(v) (*(v) += 1)
#define COUNT_PRIMS(v, n)
#endif

#define INF_T INFINITY

typedef struct {
    float3 o, d;
    float3 inv_d; /* 1/d per axis: +-inf where a component is +-0 (the slab test relies on it) */
    /* watertight triangle test (Woop, Benthin, Wald 2013): kz is the axis of d's largest
     * component, kx and ky the next two in cyclic order; the shear that maps d to +z */
    int kx, ky, kz;
    float sx, sy, sz;
} Ray;

/* component k (0, 1, 2) of v, with selects: OpenCL C has no dynamic vector indexing */
INLINE float axis_of(float3 v, int k) { return k == 0 ? v.x : (k == 1 ? v.y : v.z); }

/* Plain-arithmetic versions of min, max, dot and cross for the hot loops:
 * some OpenCL compilers (PoCL among them) leave the builtins as calls, which
 * cost a third of the traversal time.  max_f(a, b) returns b when a is NaN, so
 * chains written as max_f(x, acc) ignore NaN slab distances. */
/* |x| by clearing the sign bit: PoCL calls its fabs builtin out of line */
INLINE float abs_f(float x) { return as_float(as_uint(x) & 0x7fffffffu); }
INLINE float3 abs3(float3 v) { return as_float3(as_uint3(v) & (uint3)(0x7fffffffu)); }
INLINE float4 abs4(float4 v) { return as_float4(as_uint4(v) & (uint4)(0x7fffffffu)); }
INLINE float min_f(float a, float b) { return a < b ? a : b; }
INLINE float max_f(float a, float b) { return a > b ? a : b; }
INLINE float max3(float3 v) { return max_f(v.x, max_f(v.y, v.z)); } /* the largest component */
INLINE float dot3(float3 a, float3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
INLINE float3 cross3(float3 a, float3 b) {
    return (float3)(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x);
}

/* sqrt inline: PoCL calls its builtin out of line (a function around one vsqrtss); clang's
 * __builtin_sqrtf is the IEEE square root, correctly rounded like the hardware one it called. */
#if defined(__has_builtin)
#if __has_builtin(__builtin_sqrtf)
#define SQRT_BUILTIN 1
#endif
#endif
#ifdef SQRT_BUILTIN
INLINE float sqrt_f(float x) { return __builtin_sqrtf(x); }
#else
INLINE float sqrt_f(float x) { return sqrt(x); } /* a compiler without clang's builtins */
#endif
INLINE float norm(float3 a) { return sqrt_f(dot3(a, a)); }
INLINE float3 unit(float3 a) { return a / sqrt_f(dot3(a, a)); }

/* The watertight triangle test's permutation and shear of a ray (see Ray). */
INLINE void shear_ray(Ray *r) {
    float3 d = r->d;
    float3 a = abs3(d);
    r->kz = (a.x > a.y) ? (a.x > a.z ? 0 : 2) : (a.y > a.z ? 1 : 2);
    r->kx = r->kz == 2 ? 0 : r->kz + 1;
    r->ky = r->kx == 2 ? 0 : r->kx + 1;
    float dz = axis_of(d, r->kz);
    r->sx = -axis_of(d, r->kx) / dz;
    r->sy = -axis_of(d, r->ky) / dz;
    r->sz = 1.0f / dz;
}

/* A ray for the box tests only (origin, direction, 1/d); shear_ray before any triangle test. */
INLINE Ray make_box_ray(float3 o, float3 d) {
    Ray r;
    r.o = o;
    r.d = d;
    r.inv_d = (float3)(1.0f) / d;
    r.kx = r.ky = r.kz = 0;
    r.sx = r.sy = r.sz = 0.0f;
    return r;
}

INLINE Ray make_ray(float3 o, float3 d) {
    Ray r = make_box_ray(o, d);
    shear_ray(&r);
    return r;
}

/* A region of an arena: `arena` is one buffer, `at` a region's byte offset in it (the launch records' SceneTables,
 * WorldRegions and OutRegions, clrender/layout.py; packed by clrender/arena.py), `type` its records. */
#define REGION(arena, type, at) ((__global type *)((arena) + (at)))

#endif
