/* The walker: BVH traversal written once (madmann91/bvh's traversal with a leaf function, in OpenCL C 1.2: macros
 * stand for the template parameters), included once per tree, walked state and kind of query.  Its parameters,
 * defined before the #include and undefined here after use:
 *   walk_root, walk_step       the names of the wide walk's functions (the includer's, e.g. #define walk_step
 *                              mesh_step_any); one ray also walk_start, walk_finish, walk_wide, walk_binary
 *   WALK_ANY       0: closest hit (keys nearest first; an entry beyond the nearest hit so far is dropped); 1: any-hit
 *                  (keys farthest first, no cull; the walk ends when WALK_DONE).  A constant: each include is one kind
 *   WALK_WIDE      1: wide nodes (WideNode: a node's boxes tested in lanes, the hit lanes pushed as lane keys, the
 *                  walk stepped one stack entry at a time); 0: binary nodes (BvhNode; one ray only)
 *   WALK_NODES(g)  the node array, its root at 0 (g->nodes, g->top)
 *   WALK_ROOT(g)   whether the tree has a root to enter (it holds something)
 *   WALK_STATE     what walks: a type holding the stack (sp, overflow, stack_key[], stack_node[]) and whatever its
 *                  hooks keep (Packet: eight rays; ShaftWalk: a shaft).  Left undefined: one ray (Walk), with the
 *                  hooks below written here from two of the includer's:
 *                    WALK_RAY_LEAF  fn(g, first, count, own_box, r, t_min, t_max, pass, best, T, visits) meets a
 *                                   leaf's `count` items from `first` (own_box: a wide leaf lane of one item, whose
 *                                   box is the item's own); closest hit keeps the nearest in *best, any-hit
 *                                   multiplies *T
 *                    WALK_EVERY     the same for every item of the tree, after a stack filled up (no node is dropped)
 *                    WALK_SORT_ANY  binary nodes, any-hit: 1 the nearer child first, as closest hit; 0 the far first
 *   WALK_CONTEXT   what the hooks read beside the state, passed along unchanged (one ray: its Pass)
 *   WALK_ENTRY(w, c, sp, key)          which of the state's rays still need stack entry sp, a mask (0: drop it)
 *   WALK_VISIT(w, c, rays, count)      count a visit of those rays: a node's boxes (count 0) or a leaf (count > 0)
 *   WALK_PUSH(w, g, c, node, rays, size) test node's boxes with those rays and push the lanes hit (keys whose lane
 *                                      is key_lane(key, WALK_ANY)) from `size`, the stack's size; a full stack sets
 *                                      w->overflow
 *   WALK_LEAF(w, g, c, first, count, rays)  the leaf hook: `count` items from `first` met by those rays
 *   WALK_DONE(w, c)                    nothing is left to find: any-hit, every ray blocked (one ray: T is 0) */

#ifndef WALK_STATE /* ---------------------------------------------------------------- one ray: Walk */
#define WALK_ONE_RAY 1
#define WALK_STATE Walk
#define WALK_CONTEXT Pass
#define WALK_FAR(w) (WALK_ANY ? (w)->t_max : (w)->best.t) /* what culls a box: the segment, or the nearest hit */
#define WALK_ENTRY(w, c, sp, key) (WALK_ANY || !(key_t(key) > WALK_FAR(w) * BOX_EXIT_WIDEN))
#define WALK_VISIT(w, c, rays, count) COUNT_NODE(&(w)->visits)
#define WALK_PUSH(w, g, c, node, rays, size)                                                                          \
    ((w)->sp = push_lanes(node, hit_boxes((w)->r, WALK_NODES(g) + (node), WALK_FAR(w)), WALK_ANY, (w)->sort_always,   \
                          (w)->stack_key, (w)->stack_node, size, &(w)->overflow))
#define WALK_LEAF(w, g, c, first, count, rays)                                                                        \
    WALK_RAY_LEAF(g, first, count, true, (w)->r, (w)->t_min, (w)->t_max, c, &(w)->best, &(w)->T, &(w)->visits)
#define WALK_DONE(w, c) (WALK_ANY && (w)->T == 0.0f)
#endif

#if WALK_WIDE
/* Enter the root: its boxes tested with `rays` and the lanes hit pushed (the state set up, its stack empty). */
INLINE void walk_root(WALK_STATE *w, const Geometry *g, WALK_CONTEXT c, uint rays) {
    if (!WALK_ROOT(g)) return;
    WALK_VISIT(w, c, rays, 0);
    WALK_PUSH(w, g, c, 0, rays, 0);
}

/* Visit the lane on top of the stack with the rays that still need it: a leaf's items by WALK_LEAF, a node's boxes
 * tested and its hit lanes pushed.  Call while w->sp > 0. */
INLINE void walk_step(WALK_STATE *w, const Geometry *g, WALK_CONTEXT c) {
    int sp = --w->sp;
    uint key = w->stack_key[sp];
    uint rays = WALK_ENTRY(w, c, sp, key);
    if (rays == 0) return; /* closest hit: beyond the nearest hit so far; any-hit: its rays blocked */
    __global const WideNode *node = WALK_NODES(g) + w->stack_node[sp];
    int lane = key_lane(key, WALK_ANY);
    int child = LANE_OF(int, node->child, lane), count = LANE_OF(int, node->count, lane);
    if (count < 0) return; /* an empty lane: only a NaN ray meets its [+inf, -inf] box; never descend */
    WALK_VISIT(w, c, rays, count);
    if (count > 0) {
        WALK_LEAF(w, g, c, child, count, rays);
        if (WALK_DONE(w, c)) w->sp = 0;
    } else {
        WALK_PUSH(w, g, c, child, rays, sp);
    }
}

#if WALK_ONE_RAY
/* Start a wide walk of ray r over (t_min, t_max) from *best and T as they stand: the root's hit lanes pushed.
 * sort_always: push_lanes' choice (the query kernels' incoherent rays), else renders' coherent rays. */
INLINE void walk_start(Walk *w, const Geometry *g, Ray r, float t_min, float t_max, const Hit *best, float T,
                       bool sort_always) {
    w->r = r; w->t_min = t_min; w->t_max = t_max;
    w->best = *best; w->T = T;
    w->sp = 0; w->overflow = false; w->visits = 0; w->sort_always = sort_always;
    walk_root(w, g, opaque_pass(), 1u);
}

/* After the last step: a lane that did not fit on the stack means every item is met instead, any-hit from T_start. */
INLINE void walk_finish(Walk *w, const Geometry *g, Pass pass, float T_start) {
    if (!w->overflow || WALK_DONE(w, pass)) return;
    if (WALK_ANY) w->T = T_start;
    WALK_EVERY(g, w->r, w->t_min, w->t_max, pass, &w->best, &w->T, &w->visits);
}

/* The whole walk: start, steps, finish.  `shear`: r is a box ray (make_box_ray), sheared for the triangle tests only
 * once the root has a hit (three divisions most rays of a small mesh never need). */
INLINE void walk_wide(const Geometry *g, Ray r, float t_min, float t_max, Pass pass, bool sort_always, bool shear,
                      Hit *best, float *T, uint *visits) {
    Walk w;
    walk_start(&w, g, r, t_min, t_max, best, *T, sort_always);
    if (shear && (w.sp > 0 || w.overflow)) shear_ray(&w.r);
    while (w.sp > 0) walk_step(&w, g, pass);
    walk_finish(&w, g, pass, *T);
    *visits += w.visits;
    *best = w.best;
    *T = w.T;
}
#endif

#else
/* A binary walk of ray r over (t_min, t_max) from *best and *T as they stand, depth first: at an interior node the
 * child to visit next, the other on the stack (closest hit: the nearer box next, ties to the near child node + 1).
 * Trees are at most MAX_TREE_LEVELS deep, so the stack holds at most depth - 1 nodes; should it fill up anyway,
 * WALK_EVERY at the end.  sort_always and shear: as the wide walk's (a binary walk takes a sheared ray). */
INLINE void walk_binary(const Geometry *g, Ray r, float t_min, float t_max, Pass pass, bool sort_always, bool shear,
                        Hit *best, float *T, uint *visits) {
    __global const BvhNode *nodes = (__global const BvhNode *)WALK_NODES(g);
    bool by_distance = !WALK_ANY || WALK_SORT_ANY;
    int stack[STACK_SIZE];
    float stack_t[STACK_SIZE];
    int sp = 0;
    bool overflow = false;
    float T_start = *T;
    int node = (WALK_ROOT(g) && hit_box(r, nodes, WALK_ANY ? t_max : best->t) != INF_T) ? 0 : -1;
    while (node >= 0) {
        COUNT_NODE(visits);
        int count = nodes[node].count, offset = nodes[node].offset;
        int next = -1;
        if (count > 0) {
            WALK_RAY_LEAF(g, offset, count, false, r, t_min, t_max, pass, best, T, visits);
            if (WALK_ANY && *T == 0.0f) return; /* blocked: done */
        } else {
            float t_far = WALK_ANY ? t_max : best->t;
            int first = by_distance ? node + 1 : offset, second = by_distance ? offset : node + 1;
            float t_first = hit_box(r, nodes + first, t_far), t_second = hit_box(r, nodes + second, t_far);
            if (by_distance && t_second < t_first) { /* visit the nearer box first */
                int tmp = first; first = second; second = tmp;
                float tt = t_first; t_first = t_second; t_second = tt;
            }
            if (t_first != INF_T) {
                next = first;
                if (t_second != INF_T) { /* put the other node on the stack */
                    if (sp < STACK_SIZE) { stack[sp] = second; stack_t[sp] = t_second; ++sp; }
                    else overflow = true;
                }
            } else if (t_second != INF_T) { /* unsorted any-hit only: sorted, a hit box comes first */
                next = second;
            }
        }
        /* advance to the next node, else pop a stacked node the ray can still reach */
        while (next < 0 && sp > 0) {
            --sp;
            if (WALK_ANY || stack_t[sp] <= best->t * BOX_EXIT_WIDEN) next = stack[sp];
        }
        node = next;
    }
    if (!overflow) return;
    if (WALK_ANY) *T = T_start;
    WALK_EVERY(g, r, t_min, t_max, pass, best, T, visits);
}
#endif

#undef walk_root
#undef walk_step
#undef walk_start
#undef walk_finish
#undef walk_wide
#undef walk_binary
#undef WALK_ANY
#undef WALK_WIDE
#undef WALK_NODES
#undef WALK_ROOT
#undef WALK_STATE
#undef WALK_ONE_RAY
#undef WALK_FAR
#undef WALK_RAY_LEAF
#undef WALK_EVERY
#undef WALK_SORT_ANY
#undef WALK_CONTEXT
#undef WALK_ENTRY
#undef WALK_VISIT
#undef WALK_PUSH
#undef WALK_LEAF
#undef WALK_DONE
