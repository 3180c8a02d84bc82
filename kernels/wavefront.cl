/* The path tracer's wavefront schedule (docs/lanes.md; Laine, Karras and Aila 2013, "Megakernels considered harmful"):
 * kernels/path.cl's steps, one kernel each, over slots that each hold one path in a PathState record
 * (clrender/layout.py).  Slot i takes pixel pixels[i]'s samples in order: when its path ends, wave_advance adds it to
 * the pixel's sums and starts the pixel's next sample in the same slot, so each pixel's sums are made in the
 * megakernel's order and the images are its bits.  clrender/trace/wavefront.py launches, each bounce:
 *   wave_extend   the closest hit of each live path's ray (one ray per work-item: the BVH walk, scalar);
 *   wave_shade    emission, NEE (its shadow ray left in the record), the BSDF's next ray: no traversal, so Intel's
 *                 OpenCL CPU runtime compiles a copy with 16 work-items in the lanes of a zmm register (it runs that
 *                 copy for 16-item work-groups only, and it is slower: docs/lanes.md);
 *   wave_occlude  each shadow ray's any-hit, and its radiance where nothing blocks it;
 *   wave_advance  finished paths into their pixel's sums, the pixel's next sample or its outputs; live[0] counts the
 *                 slots still live (the host's occupancy and its stop).
 * The extend and occlude kernels take the rng for a stochastic alpha test's draws (rng.h's rng_extra: their own counter,
 * so their order against the vertex's other draws changes no number). */
#define PATH_STEPS_ONLY 1 /* path.cl's steps without its render_path */
#include "path.cl"

/* Slot st's Rng: (seed, pixel, sample) and where the path is in its stream. */
INLINE Rng state_rng(const PathParams *p, const PathState *st) {
    Rng r = make_rng(p->frame.seed, (uint)st->pixel, (uint)p->first_sample + st->sample);
    r.dim = st->rng_dim;
    r.base = st->rng_base;
    r.extra = st->rng_extra;
    return r;
}

INLINE void save_rng(PathState *st, const Rng *r) {
    st->rng_dim = r->dim;
    st->rng_base = r->base;
    st->rng_extra = r->extra;
}

INLINE void save_hit(PathState *st, Hit h) {
    st->hit_t = h.t;
    st->hit_slot = h.slot;
    st->hit_id = h.id;
    st->hit_u = h.u;
    st->hit_v = h.v;
#if INSTANCED
    st->hit_instance = h.instance;
#else
    st->hit_instance = -1;
#endif
}

INLINE Hit state_hit(const PathState *st) {
    Hit h;
    h.t = st->hit_t;
    h.slot = st->hit_slot;
    h.id = st->hit_id;
    h.u = st->hit_u;
    h.v = st->hit_v;
#if INSTANCED
    h.instance = st->hit_instance;
#endif
    return h;
}

/* What each kernel reads (IN) and writes back (OUT) of its slot's record: only those fields cross memory (a whole
 * record is 284 bytes, and a bounce runs three kernels over every slot).  X-lists: X(f) a field, X3(f) a 3-vector. */
#define IN(f) st.f = g->f;
#define IN3(f) IN(f[0]) IN(f[1]) IN(f[2])
#define OUT(f) g->f = st.f;
#define OUT3(f) OUT(f[0]) OUT(f[1]) OUT(f[2])
#define RNG_FIELDS(X) X(pixel) X(sample) X(rng_dim) X(rng_base) X(rng_extra)
#define HIT_FIELDS(X) X(hit_t) X(hit_slot) X(hit_id) X(hit_u) X(hit_v) X(hit_instance)
#define PATH_FIELDS(X, X3) X3(o) X3(d) X3(beta) X(eta_scale) X3(radiance) X3(prev_n) X(prev_pdf) X(prev_delta) X(depth)
#define SHADOW_FIELDS(X, X3) X(shadowed) X3(shadow_o) X3(shadow_d) X(shadow_t_max) X3(shadow_l) X3(shadow_beta)
#define FIRST_HIT_FIELDS(X, X3) X3(fh_normal) X3(fh_albedo) X(fh_depth) X(fh_object)

/* the scene of the kernels that take its buffers */
#define PATH_SCENE path_scene(nodes, prims, prim_object, normals, attributes, texels, tables, world, params)

/* Slot gid takes pixel pixels[gid]: its sums cleared (and its splat slots) and its first sample started. */
__kernel void wave_start(__global const int *pixels, PathParams params, __global char *out, __global PathState *states) {
    int gid = get_global_id(0);
    if (gid >= params.frame.n_work) return;
    PathState st = {0}; /* every field written: the later kernels copy whole parts of the record */
    start_pixel(&st);
    Rng rng;
    start_sample(&params, &st, pixels[gid], 0u, &rng, true);
    save_rng(&st, &rng);
    st.live = 1;
#if SPLAT_RADIUS
    __global float4 *splats = REGION(out, float4, params.frame.out.colour) + gid * SPLAT_SLOTS;
    for (int k = 0; k < SPLAT_SLOTS; ++k) splats[k] = (float4)(0.0f);
#endif
    states[gid] = st;
}

/* The closest hit of each live path's ray. */
__kernel void wave_extend(__global const TreeNode *nodes, __global const PrimSlot *prims, __global const int *prim_object,
                          __global const VertexNormals *normals, __global const VertexAttributes *attributes,
                          __global const float4 *texels, __global const char *tables, __global const char *world,
                          PathParams params, __global PathState *states) {
    int gid = get_global_id(0);
    if (gid >= params.frame.n_work || !states[gid].live || states[gid].ended) return;
    PathScene s = PATH_SCENE;
    __global PathState *g = states + gid;
    PathState st;
    IN3(o) IN3(d) IN(depth) IN(visits) IN(rays) RNG_FIELDS(IN)
    Rng rng = state_rng(&params, &st);
    save_hit(&st, extend_step(&s, &st, &rng));
    save_rng(&st, &rng);
    OUT(visits) OUT(rays) RNG_FIELDS(OUT) HIT_FIELDS(OUT)
}

/* Each live path's vertex at its hit: no traversal (the driver's lanes). */
__kernel void wave_shade(__global const TreeNode *nodes, __global const PrimSlot *prims, __global const int *prim_object,
                          __global const VertexNormals *normals, __global const VertexAttributes *attributes,
                          __global const float4 *texels, __global const char *tables, __global const char *world,
                          PathParams params, __global PathState *states) {
    int gid = get_global_id(0);
    if (gid >= params.frame.n_work || !states[gid].live || states[gid].ended) return;
    PathScene s = PATH_SCENE;
    __global PathState *g = states + gid;
    PathState st;
    PATH_FIELDS(IN, IN3) IN(rays) RNG_FIELDS(IN) HIT_FIELDS(IN)
    st.ended = 0;
    bool first = st.depth == 0; /* shade_step sets the sample's first hit */
    Rng rng = state_rng(&params, &st);
    if (!shade_step(&s, &st, state_hit(&st), &rng, true)) st.ended = 1;
    save_rng(&st, &rng);
    PATH_FIELDS(OUT, OUT3) OUT(rays) OUT(ended) RNG_FIELDS(OUT)
    if (st.shadowed) { SHADOW_FIELDS(OUT, OUT3) } else { OUT(shadowed) } /* the ray's fields: only where there is one */
    if (first) { FIRST_HIT_FIELDS(OUT, OUT3) }
}

/* Each shadow ray NEE left: its any-hit, and its radiance where nothing blocks it. */
__kernel void wave_occlude(__global const TreeNode *nodes, __global const PrimSlot *prims, __global const int *prim_object,
                          __global const VertexNormals *normals, __global const VertexAttributes *attributes,
                          __global const float4 *texels, __global const char *tables, __global const char *world,
                          PathParams params, __global PathState *states) {
    int gid = get_global_id(0);
    if (gid >= params.frame.n_work || !states[gid].live || !states[gid].shadowed) return;
    PathScene s = PATH_SCENE;
    __global PathState *g = states + gid;
    PathState st;
    SHADOW_FIELDS(IN, IN3) IN3(radiance) IN(visits) RNG_FIELDS(IN)
    Rng rng = state_rng(&params, &st);
    shadow_step(&st, shadow_unblocked(&s, &st, &rng));
    save_rng(&st, &rng);
    OUT(shadowed) OUT3(radiance) OUT(visits) RNG_FIELDS(OUT)
}

/* Each ended path into its pixel's sums, then the pixel's next sample in the slot, or (its last done) its outputs;
 * live[0] counts the slots still live after. */
__kernel void wave_advance(PathParams params, __global char *out, __global PathState *states, __global uint *live) {
    int gid = get_global_id(0);
    if (gid >= params.frame.n_work || !states[gid].live) return;
    if (states[gid].ended) {
        PathState st = states[gid];
        float4 splats[SPLAT_SLOTS];
#if SPLAT_RADIUS
        __global float4 *slots = REGION(out, float4, params.frame.out.colour) + gid * SPLAT_SLOTS;
        for (int k = 0; k < SPLAT_SLOTS; ++k) splats[k] = slots[k];
#endif
        finish_sample(&st, splats, true);
#if SPLAT_RADIUS
        for (int k = 0; k < SPLAT_SLOTS; ++k) slots[k] = splats[k];
#endif
        if (st.sample + 1u < (uint)params.spp) {
            Rng rng;
            start_sample(&params, &st, st.pixel, st.sample + 1u, &rng, true);
            save_rng(&st, &rng);
        } else {
            st.live = 0;
            write_pixel(&params, gid, out, vload3(0, st.sum), st.weight_sum, vload3(0, st.normal_sum), vload3(0, st.albedo_sum),
                        st.first_object, st.first_depth, st.visits, st.rays);
        }
        states[gid] = st;
        if (!st.live) return;
    }
    atomic_inc(live);
}
