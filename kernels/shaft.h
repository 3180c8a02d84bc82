/* Shadow rays toward an area light through one shaft (Haines and Wallace, "Shaft culling for
 * efficient ray-cast radiosity", 1994).  Every shadow ray of a shading point toward a parallelogram
 * light starts at the same origin O and ends on (a hair off) the light, so all of them lie in the
 * shaft: the convex hull of O and the light's four corners, the intersection of five half-spaces
 * (four side planes through O and two adjacent corners, and the light's own plane).  One traversal
 * of the wide BVH with the shaft collects the triangles and spheres that may meet it (the
 * candidates); each ray is then tested only against those, with the per-ray traversal's own tests
 * (hit_block, crossing_transmittance), so it finds the same crossings and the same transmittance.
 *
 * Conservative: a box or primitive is left out only when it lies beyond one plane (or outside the
 * shaft's bounds) by more than SHAFT_MARGIN times the size of the coordinates involved, far above
 * float32 rounding (about 6e-8 per operation) and above how far a shadow ray strays from the exact
 * shaft (its origin is offset a few ulps off the surface, its direction is rounded).  The caller
 * falls back to the per-ray traversal when the shaft is flat, when the light is not clearly on one
 * side of the surface (rays would start from both sides), or when there are more than
 * SHAFT_CANDIDATES candidate blocks.  Needs the wide tree (BVH_WIDTH 4 or 8): blocks are its leaf
 * blocks (LeafBlock, clrender/layout.py). */
#ifndef CLRENDER_SHAFT_H
#define CLRENDER_SHAFT_H

#include "common.h"
#include "intersect.h"
/* triangle_test8: two candidate blocks against a ray at once (hit_block_pair) */
#include "packet.h"

#ifndef SHADOW_SHAFTS
#error "SHADOW_SHAFTS is missing: build trace.cl with clrender.trace.tracer.trace_defines()"
#endif
/* the binary tree and BVH-off keep per-ray rays, and so do alpha-tested scenes (alpha.h: each shadow ray walks its
   hits one by one, reading textures) */
#define SHAFTS_ON (SHADOW_SHAFTS && USE_BVH && BVH_WIDTH >= 4 && !ALPHA_TEST && !INSTANCED) /* instances: walk_instances any-hit */

#if SHAFTS_ON
#ifndef SHAFT_CANDIDATES
#error "SHAFT_CANDIDATES is missing: build trace.cl with clrender.trace.tracer.trace_defines()"
#endif

#define SHAFT_MARGIN 1e-5f /* relative to the coordinates: float32 rounding is ~6e-8 per operation */

typedef struct {
    float4 plane[5]; /* outward normal (xyz, |n|_1 = 1) and w = dot(n, a point on the plane): outside where dot(n, x) > w */
    float3 apex, corner[4]; /* O, and the light's corners in order around it */
    float3 lo, hi;   /* bounds of O and the corners */
    float scale;     /* largest |coordinate| of O and the corners */
} Shaft;

/* Candidates: leaf blocks with the lanes (bits 0..3) that may meet the shaft, or a sphere,
 * stored as first = -2 - slot, lanes = 0. */
typedef struct {
    int first[SHAFT_CANDIDATES];
    int lanes[SHAFT_CANDIDATES];
    int n;
    float crossed_T; /* transmittance of the spheres every ray crosses once (not in the list) */
} ShaftCandidates;

INLINE float max3_abs(float3 v) { return max3(abs3(v)); }
INLINE float4 max4(float4 a, float4 b) { return a > b ? a : b; } /* ?: rather than max(), a call on PoCL */

/* Which side of the surface (unit normal n_geo at p) the whole light is on: 1 in front, -1 behind,
 * 0 when a corner is within the margin of the tangent plane (rays might start on either side). */
INLINE int light_side(float3 p, float3 n_geo, float3 corner, float3 a, float3 b) {
    float3 c[4] = {corner, corner + a, corner + a + b, corner + b};
    float scale = max3_abs(p);
    float lo = INFINITY, hi = -INFINITY;
    for (int i = 0; i < 4; ++i) {
        scale = max_f(scale, max3_abs(c[i]));
        float s = dot3(n_geo, c[i] - p);
        lo = min_f(lo, s);
        hi = max_f(hi, s);
    }
    float margin = SHAFT_MARGIN * scale;
    return lo > margin ? 1 : (hi < -margin ? -1 : 0);
}

/* n / |n|_1 (NaN when n is zero or not finite): 1/sqrt(3) <= |result| <= 1, so n.x - w is at most
 * the distance from the plane, never more: every margin test below stays conservative, and no
 * sqrt (a call on PoCL) is needed. */
INLINE float3 unit_l1(float3 n) {
    float3 a = abs3(n);
    float len = a.x + a.y + a.z;
    bool ok = len > 0.0f && len < INFINITY;
    return ok ? n * (1.0f / len) : (float3)(NAN);
}

/* Side plane through o, c and d, oriented so that `inside` (the light's centre) is inside.  False
 * when the plane is ill-defined or `inside` is not clearly inside it (o on the light's plane). */
INLINE bool side_plane(float3 o, float3 c, float3 d, float3 inside, float margin, float4 *plane) {
    float3 n = unit_l1(cross3(c - o, d - o));
    if (!(n.x == n.x)) return false; /* NaN: degenerate */
    float w = dot3(n, o);
    float f = dot3(n, inside) - w;
    if (f > 0.0f) { n = -n; w = -w; f = -f; }
    *plane = (float4)(n, w);
    return f < -margin;
}

/* The shaft from o to the parallelogram corner + [0,1] a + [0,1] b.  False when it is too flat to
 * trust (the caller then traces each ray). */
INLINE bool make_shaft(float3 o, float3 corner, float3 a, float3 b, Shaft *sh) {
    float3 c[4] = {corner, corner + a, corner + a + b, corner + b};
    float3 centre = corner + 0.5f * a + 0.5f * b;
    float scale = max3_abs(o);
    float3 lo = o, hi = o;
    for (int i = 0; i < 4; ++i) {
        scale = max_f(scale, max3_abs(c[i]));
        lo = (float3)(min_f(lo.x, c[i].x), min_f(lo.y, c[i].y), min_f(lo.z, c[i].z));
        hi = (float3)(max_f(hi.x, c[i].x), max_f(hi.y, c[i].y), max_f(hi.z, c[i].z));
    }
    sh->apex = o;
    for (int i = 0; i < 4; ++i) sh->corner[i] = c[i];
    sh->scale = scale;
    sh->lo = lo;
    sh->hi = hi;
    float margin = 4.0f * SHAFT_MARGIN * scale;
    bool ok = true;
    for (int i = 0; i < 4; ++i) ok &= side_plane(o, c[i], c[(i + 1) & 3], centre, margin, &sh->plane[i]);
    /* the light's plane, with o inside */
    float3 n = unit_l1(cross3(a, b));
    if (!(n.x == n.x)) return false;
    float w = dot3(n, corner);
    float f = dot3(n, o) - w;
    if (f > 0.0f) { n = -n; w = -w; f = -f; }
    sh->plane[4] = (float4)(n, w);
    return ok && f < -margin;
}

/* Lanes of a wide node whose boxes may meet the shaft (and are not empty). */
INLINE lanes_i shaft_boxes(const Shaft *sh, __global const WideNode *node) {
    __global const lanes_f *b = node->bounds; /* lo, hi along x, then y, then z */
    lanes_f ext = as_lanes_f(as_lanes_u(b[0]) & 0x7fffffffu);
    for (int r = 1; r < 6; ++r) {
        lanes_f e = as_lanes_f(as_lanes_u(b[r]) & 0x7fffffffu);
        ext = e > ext ? e : ext;
    }
    lanes_f m = SHAFT_MARGIN * (sh->scale + ext);
    lanes_i keep = (node->count >= 0) & (b[0] <= sh->hi.x + m) & (b[1] >= sh->lo.x - m) & (b[2] <= sh->hi.y + m) &
                   (b[3] >= sh->lo.y - m) & (b[4] <= sh->hi.z + m) & (b[5] >= sh->lo.z - m);
    for (int i = 0; i < 5; ++i) {
        float4 p = sh->plane[i];
        /* the box corner deepest inside the plane: lo where n > 0, hi where n < 0 */
        lanes_f f = p.x * b[p.x > 0.0f ? 0 : 1] + p.y * b[p.y > 0.0f ? 2 : 3] + p.z * b[p.z > 0.0f ? 4 : 5] - p.w;
        keep &= f <= m;
    }
    return keep;
}

/* n . (x - v0) for the lanes' planes n = (v1 - v0) x (v2 - v0), and a bound on its float32 error:
 * 2^-20 (about 16 ulps) times the same sum with every product taken in absolute value (the
 * products' exact zeros stay exact, so an axis-aligned plane's sides come out exactly). */
#define PLANE_SIDE(qx, qy, qz, s, err) { \
    float4 qx_ = (qx) - x0, qy_ = (qy) - y0, qz_ = (qz) - z0; \
    s = nx * qx_ + ny * qy_ + nz * qz_; \
    err = 9.5367431640625e-7f * (px * abs4(qx_) + py * abs4(qy_) + pz * abs4(qz_)); }

/* Lanes whose triangle's plane has the whole shaft strictly on one side: the origin O on a side
 * that rounding cannot change, and every light corner on the same side by more than the margin
 * `m` (a distance).  No ray from O towards the light can cross such a triangle: the ray's true
 * crossing of the plane lies behind O or well beyond the light, outside the triangle test's own
 * error bound on t.  This removes the triangles around the shading point on a convex surface
 * and a plane's other triangle, which the five planes cannot: they pass just beside the apex. */
INLINE int4 shaft_beside_planes(const Shaft *sh, float4 x0, float4 y0, float4 z0, float4 x1, float4 y1, float4 z1,
                                float4 x2, float4 y2, float4 z2, float4 m) {
    float4 ax = x1 - x0, ay = y1 - y0, az = z1 - z0, bx = x2 - x0, by = y2 - y0, bz = z2 - z0;
    float4 nx = ay * bz - az * by, ny = az * bx - ax * bz, nz = ax * by - ay * bx;
    float4 px = abs4(ay * bz) + abs4(az * by), py = abs4(az * bx) + abs4(ax * bz), pz = abs4(ax * by) + abs4(ay * bx);
    float4 m_n = m * (px + py + pz); /* the margin times a bound on |n| */
    float4 s, err;
    PLANE_SIDE(sh->apex.x, sh->apex.y, sh->apex.z, s, err);
    int4 front = s > err, back = s < -err;
    for (int i = 0; i < 4; ++i) {
        float3 c = sh->corner[i];
        PLANE_SIDE(c.x, c.y, c.z, s, err);
        front &= s > err + m_n;
        back &= s < -(err + m_n);
    }
    return front | back;
}
#undef PLANE_SIDE

/* Triangle lanes of a leaf block that may meet the shaft (bits 0..3); `own` (the shading point's
 * slot) is left out: the caller uses shafts only when the whole light is clearly on the side the
 * rays leave towards, so no ray from the offset origin can cross the surface it starts on. */
INLINE int shaft_triangles(const Shaft *sh, __global const LeafBlock *block, int own) {
    float4 x0 = block->v0[0], y0 = block->v0[1], z0 = block->v0[2], x1 = block->v1[0], y1 = block->v1[1], z1 = block->v1[2];
    float4 x2 = block->v2[0], y2 = block->v2[1], z2 = block->v2[2];
    float4 e0 = max4(abs4(x0), max4(abs4(y0), abs4(z0))), e1 = max4(abs4(x1), max4(abs4(y1), abs4(z1)));
    float4 e2 = max4(abs4(x2), max4(abs4(y2), abs4(z2)));
    float4 m0 = SHAFT_MARGIN * (sh->scale + e0), m1 = SHAFT_MARGIN * (sh->scale + e1), m2 = SHAFT_MARGIN * (sh->scale + e2);
    int4 out = ((x0 > sh->hi.x + m0) & (x1 > sh->hi.x + m1) & (x2 > sh->hi.x + m2)) |
               ((x0 < sh->lo.x - m0) & (x1 < sh->lo.x - m1) & (x2 < sh->lo.x - m2)) |
               ((y0 > sh->hi.y + m0) & (y1 > sh->hi.y + m1) & (y2 > sh->hi.y + m2)) |
               ((y0 < sh->lo.y - m0) & (y1 < sh->lo.y - m1) & (y2 < sh->lo.y - m2)) |
               ((z0 > sh->hi.z + m0) & (z1 > sh->hi.z + m1) & (z2 > sh->hi.z + m2)) |
               ((z0 < sh->lo.z - m0) & (z1 < sh->lo.z - m1) & (z2 < sh->lo.z - m2));
    for (int i = 0; i < 5; ++i) {
        float4 p = sh->plane[i];
        float4 f0 = p.x * x0 + p.y * y0 + p.z * z0 - p.w;
        float4 f1 = p.x * x1 + p.y * y1 + p.z * z1 - p.w;
        float4 f2 = p.x * x2 + p.y * y2 + p.z * z2 - p.w;
        out |= (f0 > m0) & (f1 > m1) & (f2 > m2);
    }
    int4 slot = block->slot;
    int4 keep = (slot >= 0) & (slot != own) & (out == 0);
    if (!(keep.x | keep.y | keep.z | keep.w)) return 0; /* far blocks: the planes suffice */
    keep &= shaft_beside_planes(sh, x0, y0, z0, x1, y1, z1, x2, y2, z2, max4(m0, max4(m1, m2))) == (int4)(0);
    return (keep.x & 1) | (keep.y & 2) | (keep.z & 4) | (keep.w & 8);
}

/* What the shaft's rays do at the sphere (centre, radius): SPHERE_MISSED, SPHERE_TESTED (each ray
 * is tested), or SPHERE_CROSSED_ONCE.  Computed as sphere_roots computes c = |O - centre|^2 - r^2
 * (contraction off, as there), which is the same for every ray from O:
 * - missed: outside the shaft's bounds, or O outside (c > 0) and every ray leaving it (b = (O -
 *   centre) . d > 0 by a margin at every corner): both roots are then negative.
 * - crossed once: O inside (c < 0), every ray heading in (b < -0.02 |O - centre| at every corner, so
 *   the discriminant is clearly positive and the far root is a chord of at least 0.04 r, far above
 *   sphere_t_eps) and the sphere wholly on O's side of the light's plane (the exit comes before
 *   t_max): one root negative, the other counted.  The glass sphere seen from inside is such. */
#define SPHERE_MISSED 0
#define SPHERE_TESTED 1
#define SPHERE_CROSSED_ONCE 2
#pragma OPENCL FP_CONTRACT OFF
INLINE int shaft_sphere(const Shaft *sh, float4 cr) {
    float m = SHAFT_MARGIN * (sh->scale + max3_abs(cr.xyz) + cr.w) + cr.w;
    bool keep = cr.x <= sh->hi.x + m && cr.y <= sh->hi.y + m && cr.z <= sh->hi.z + m && cr.x >= sh->lo.x - m &&
                cr.y >= sh->lo.y - m && cr.z >= sh->lo.z - m;
    /* (the five planes too cost more than the few sphere tests they saved: -5% on wizard_cat) */
    if (!keep) return SPHERE_MISSED;
    float3 oc = sh->apex - cr.xyz;
    float c = dot3(oc, oc) - cr.w * cr.w;
    float3 a = abs3(oc);
    float oc_l1 = a.x + a.y + a.z;
    if (c > 0.0f) {
        float margin = SHAFT_MARGIN * sh->scale * oc_l1;
        bool leaves = true;
        for (int i = 0; i < 4; ++i) leaves = leaves && dot3(oc, sh->corner[i] - sh->apex) > margin;
        return leaves ? SPHERE_MISSED : SPHERE_TESTED;
    }
    if (c < 0.0f) {
        bool enters = dot3(sh->plane[4].xyz, cr.xyz) - sh->plane[4].w < -m; /* m includes r */
        for (int i = 0; i < 4; ++i) {
            float3 to = sh->corner[i] - sh->apex, at = abs3(to);
            enters = enters && dot3(oc, to) < -0.02f * oc_l1 * (at.x + at.y + at.z);
        }
        if (enters) return SPHERE_CROSSED_ONCE;
    }
    return SPHERE_TESTED;
}
#pragma OPENCL FP_CONTRACT ON

/* Add the candidates of one wide leaf (`count` primitives in blocks from `first` on) to `cand`: its
 * blocks' triangle lanes that may meet the shaft, and its spheres (or, for a sphere every ray crosses
 * once, its transparency in crossed_T).  False when they do not fit. */
INLINE bool shaft_leaf(const Shaft *sh, const Geometry *g, Pass pass, int first, int count, int own, ShaftCandidates *cand) {
    __global const LeafBlock *block = leaf_block(g, first);
    for (int b = 0; b < count; b += BLOCK_LANES, ++first, ++block) {
        int lanes = shaft_triangles(sh, block, own);
        if (lanes) {
            if (cand->n >= SHAFT_CANDIDATES) return false;
            cand->first[cand->n] = first;
            cand->lanes[cand->n++] = lanes;
        }
        int4 slot = block->slot;
        if (!(slot.x < -1 || slot.y < -1 || slot.z < -1 || slot.w < -1)) continue; /* spheres: -2 - slot */
        int sl[4] = {slot.x, slot.y, slot.z, slot.w};
        for (int q = 0; q < BLOCK_LANES; ++q) {
            if (sl[q] >= -1) continue;
            __global const SphereSlot *sphere = sphere_slot(g, -2 - sl[q]);
            int what = shaft_sphere(sh, centre_radius(sphere));
            if (what == SPHERE_MISSED) continue;
            if (what == SPHERE_CROSSED_ONCE) {
                cand->crossed_T *= transparency_of(g, pass, sphere->id);
                continue;
            }
            if (cand->n >= SHAFT_CANDIDATES) return false;
            cand->first[cand->n] = sl[q];
            cand->lanes[cand->n++] = 0;
        }
    }
    return true;
}

/* ---------------------------------------------------------------- the walker with a shaft (kernels/walk.h)
 * The state: a stack of lanes (their keys hold only the lane: the walk keeps no order of its own, sorts nothing and
 * culls nothing); the context: the shaft, the candidates it collects and the node visits.  A node's lanes that may
 * meet the shaft are pushed interior lanes first, then the leaves above them, in lane order from the top, so the
 * candidates come in the order of a depth-first walk that meets a node's leaves when it tests its boxes. */
typedef struct {
    int sp;
    bool overflow;   /* the stack or the candidates filled up: the caller traces each ray */
    uint stack_key[WIDE_STACK_SIZE + BVH_WIDTH];
    int stack_node[WIDE_STACK_SIZE + BVH_WIDTH];
} ShaftWalk;

typedef struct {
    const Shaft *sh;
    Pass pass;       /* what a sphere every ray crosses once keeps of the light (crossed_T) */
    int own;         /* the shading point's slot, left out */
    ShaftCandidates *cand;
    uint *visits;
} ShaftQuery;

/* The lanes of node (at `index`) that may meet the shaft (shaft_boxes), pushed: interior lanes in lane order, then
 * leaf lanes in reverse (popped first, in lane order).  A full stack ends the walk. */
INLINE void shaft_push(ShaftWalk *w, const ShaftQuery *c, __global const WideNode *node, int index) {
    lanes_i keep = shaft_boxes(c->sh, node);
    lanes_i leaf = node->count > (lanes_i)(0);
    int k[BVH_WIDTH] = LANES_ARRAY(keep), l[BVH_WIDTH] = LANES_ARRAY(leaf);
    for (int leaves = 0; leaves < 2; ++leaves) {
        for (int n = 0; n < BVH_WIDTH; ++n) {
            int j = leaves ? BVH_WIDTH - 1 - n : n;
            if (!k[j] || (l[j] != 0) != (leaves == 1)) continue;
            if (w->sp >= WIDE_STACK_SIZE + BVH_WIDTH) { w->overflow = true; w->sp = 0; return; }
            w->stack_key[w->sp] = ~(uint)j; /* key_lane(key, farthest_first): lane j */
            w->stack_node[w->sp++] = index;
        }
    }
}

#define walk_root shaft_root
#define walk_step shaft_step
#define WALK_ANY 1
#define WALK_WIDE 1
#define WALK_NODES(g) ((g)->nodes)
#define WALK_ROOT(g) ((g)->n_prims > 0)
#define WALK_STATE ShaftWalk
#define WALK_CONTEXT const ShaftQuery *
#define WALK_ENTRY(w, c, sp, key) 1u
#define WALK_VISIT(w, c, rays, count) if ((count) == 0) { COUNT_NODE((c)->visits); }
#define WALK_PUSH(w, g, c, node, rays, size) shaft_push(w, c, (g)->nodes + (node), node)
#define WALK_LEAF(w, g, c, first, count, rays) \
    if (!shaft_leaf((c)->sh, g, (c)->pass, first, count, (c)->own, (c)->cand)) (w)->overflow = true
#define WALK_DONE(w, c) ((w)->overflow)
#include "walk.h"

/* Collect the candidates of the shaft from the wide tree.  False when there are more than
 * SHAFT_CANDIDATES of them or the stack overflows (the caller then traces each ray). */
INLINE bool shaft_candidates(const Shaft *sh, const Geometry *g, Pass pass, int own, ShaftCandidates *cand, uint *visits) {
    ShaftQuery c;
    c.sh = sh; c.pass = pass; c.own = own; c.cand = cand; c.visits = visits;
    ShaftWalk w;
    w.sp = 0;
    w.overflow = false;
    cand->n = 0;
    cand->crossed_T = 1.0f;
    shaft_root(&w, g, &c, 1u);
    while (w.sp > 0) shaft_step(&w, g, &c);
    return !w.overflow;
}

/* Two leaf blocks' triangles against one ray, block a in the low four float8 lanes and b in the high
 * four: hit_block's float operations lane by lane (triangle.h, the ray's values the same in every
 * lane), so each half is bit for bit hit_block of its block, for about the cost of one. */
INLINE float8 hit_block_pair(Ray r, __global const LeafBlock *a, __global const LeafBlock *b, int8 valid, float t_max) {
    float ox = axis_of(r.o, r.kx), oy = axis_of(r.o, r.ky), oz = axis_of(r.o, r.kz);
#define PAIR(v, k) (float8)(a->v[k], b->v[k])
    float8 u, v;
    return triangle_test8(PAIR(v0, r.kx) - ox, PAIR(v0, r.ky) - oy, PAIR(v0, r.kz) - oz, PAIR(v1, r.kx) - ox,
                          PAIR(v1, r.ky) - oy, PAIR(v1, r.kz) - oz, PAIR(v2, r.kx) - ox, PAIR(v2, r.ky) - oy,
                          PAIR(v2, r.kz) - oz, valid, (float8)(r.sx), (float8)(r.sy), (float8)(r.sz), (float8)(0.0f),
                          (float8)(t_max), &u, &v);
#undef PAIR
}

/* The triangle lanes (bits 0..3) of a candidate as hit_block's valid mask */
INLINE int4 candidate_lanes(int lanes) { return ((int4)(lanes) & (int4)(1, 2, 4, 8)) != (int4)(0); }

/* Transmittance of one shadow ray (t in (0, t_max)) through the candidates: the crossings and
 * factors of leaf_blocks / crossing_transmittance, candidate by candidate in list order.  Two
 * block candidates in a row are tested at once (hit_block_pair); the second one's crossings count
 * only if the ray gets past the first, as one by one.  The candidate that blocked a ray moves to the
 * front, where the next ray (a neighbour) tries it first. */
INLINE float shaft_transmittance(ShaftCandidates *cand, const Geometry *g, Pass pass, Ray r, float t_max) {
    float T = cand->crossed_T;
    float4 next_t = (float4)(INF_T); /* candidate k's block hits, when the pair test before found them */
    bool have_next = false;
    for (int k = 0; k < cand->n && T > 0.0f; ++k) {
        int first = cand->first[k];
        if (first < 0) {
            T *= crossing_transmittance(g, -2 - first, r, 0.0f, t_max, pass);
        } else {
            __global const LeafBlock *block = leaf_block(g, first);
            float4 t = next_t;
            if (!have_next) {
                int second = k + 1 < cand->n ? cand->first[k + 1] : -1;
                if (second >= 0) {
                    int8 valid = (int8)(candidate_lanes(cand->lanes[k]), candidate_lanes(cand->lanes[k + 1]));
                    float8 t8 = hit_block_pair(r, block, leaf_block(g, second), valid, t_max);
                    t = t8.lo;
                    next_t = t8.hi;
                } else {
                    float4 u, v;
                    t = hit_block(r, block, candidate_lanes(cand->lanes[k]), 0.0f, t_max, &u, &v);
                }
                have_next = second >= 0;
            } else {
                have_next = false;
            }
            T = times_crossed(g, pass, block, t, T);
        }
        if (T == 0.0f && k > 0) { /* move to front */
            int f = cand->first[k], l = cand->lanes[k];
            cand->first[k] = cand->first[0]; cand->lanes[k] = cand->lanes[0];
            cand->first[0] = f; cand->lanes[0] = l;
        }
    }
    return T;
}

#endif /* SHAFTS_ON */
#endif
