/* The walker: BVH traversal written once, included once per tree it walks (kernels/intersect.h: a mesh's tree,
 * the instances' top tree), with its parameters defined before the #include and undefined here after use:
 *   walk_start, walk_step, walk_finish, walk_wide, walk_binary: the names the functions it defines take (the
 *                  includer's, e.g. #define walk_step mesh_step)
 *   WALK_WIDE      1: wide nodes (WideNode: a node's boxes tested in lanes, the hit lanes pushed as sorted lane
 *                  keys, a walk stepped one stack entry at a time: Walk); 0: binary nodes (BvhNode: near child next,
 *                  the other stacked)
 *   WALK_NODES(g)  the node array, its root at 0 (g->nodes, g->top)
 *   WALK_ROOT(g)   whether the tree has a root to enter (it holds something)
 *   WALK_LEAF      the leaf hook: fn(g, first, count, own_box, r, t_min, t_max, any_hit, pass, best, T, visits) meets
 *                  a leaf's `count` items from `first` (own_box: a wide leaf lane of one item, whose box is the
 *                  item's own); closest hit keeps the nearest in *best, any-hit multiplies *T
 *   WALK_EVERY     the same for every item of the tree, after a stack filled up (no node is ever dropped)
 *   WALK_SORT_ANY  binary nodes, any-hit: 1 the nearer child first, as closest hit; 0 the far child first, unsorted
 * Closest hit (any_hit false): best->t is the nearest hit so far and culls every box, a stacked box entered beyond it
 * is dropped.  Any-hit: the walk ends once *T is 0.  any_hit and pass are constants at every call, so each use
 * compiles to one kind of walk (madmann91/bvh's traversal with a leaf function, in OpenCL C 1.2). */

#if WALK_WIDE
/* Start a wide walk of ray r over (t_min, t_max) from *best and T as they stand: the root's hit lanes pushed. */
INLINE void walk_start(Walk *w, const Geometry *g, Ray r, float t_min, float t_max, const Hit *best, float T,
                       bool any_hit, bool sort_always) {
    w->r = r; w->t_min = t_min; w->t_max = t_max;
    w->best = *best; w->T = T;
    w->sp = 0; w->overflow = false; w->visits = 0; w->sort_always = sort_always;
    if (WALK_ROOT(g)) {
        COUNT_NODE(&w->visits);
        w->sp = push_lanes(0, hit_boxes(r, WALK_NODES(g), any_hit ? t_max : best->t), any_hit, sort_always, w->stack_key,
                           w->stack_node, 0, &w->overflow);
    }
}

/* Visit the lane on top of the stack: a leaf's items by WALK_LEAF, a node's boxes tested and its hit lanes pushed.
 * Call while w->sp > 0, with the any_hit the walk started with. */
INLINE void walk_step(Walk *w, const Geometry *g, Pass pass, bool any_hit) {
    int sp = --w->sp;
    uint key = w->stack_key[sp];
    float t_max = any_hit ? w->t_max : w->best.t;
    if (!any_hit && key_t(key) > t_max * BOX_EXIT_WIDEN) return; /* beyond the nearest hit so far */
    __global const WideNode *node = WALK_NODES(g) + w->stack_node[sp];
    int lane = key_lane(key, any_hit);
    int child = LANE_OF(int, node->child, lane), count = LANE_OF(int, node->count, lane);
    if (count < 0) return; /* an empty lane: only a NaN ray meets its [+inf, -inf] box; never descend */
    COUNT_NODE(&w->visits);
    if (count > 0) {
        WALK_LEAF(g, child, count, true, w->r, w->t_min, w->t_max, any_hit, pass, &w->best, &w->T, &w->visits);
        if (any_hit && w->T == 0.0f) w->sp = 0; /* blocked: done */
    } else {
        w->sp = push_lanes(child, hit_boxes(w->r, WALK_NODES(g) + child, t_max), any_hit, w->sort_always, w->stack_key,
                           w->stack_node, sp, &w->overflow);
    }
}

/* After the last step: a lane that did not fit on the stack means every item is met instead, any-hit from T_start. */
INLINE void walk_finish(Walk *w, const Geometry *g, Pass pass, bool any_hit, float T_start) {
    if (!w->overflow || (any_hit && w->T == 0.0f)) return;
    if (any_hit) w->T = T_start;
    WALK_EVERY(g, w->r, w->t_min, w->t_max, any_hit, pass, &w->best, &w->T, &w->visits);
}

/* The whole walk: start, steps, finish.  `shear`: r is a box ray (make_box_ray), sheared for the triangle tests only
 * once the root has a hit (three divisions most rays of a small mesh never need). */
INLINE void walk_wide(const Geometry *g, Ray r, float t_min, float t_max, bool any_hit, Pass pass, bool sort_always,
                      bool shear, Hit *best, float *T, uint *visits) {
    Walk w;
    walk_start(&w, g, r, t_min, t_max, best, *T, any_hit, sort_always);
    if (shear && (w.sp > 0 || w.overflow)) shear_ray(&w.r);
    while (w.sp > 0) walk_step(&w, g, pass, any_hit);
    walk_finish(&w, g, pass, any_hit, *T);
    *visits += w.visits;
    *best = w.best;
    *T = w.T;
}

#else
/* A binary walk of ray r over (t_min, t_max) from *best and *T as they stand, depth first: at an interior node the
 * child to visit next, the other on the stack (closest hit: the nearer box next, ties to the near child node + 1).
 * Trees are at most MAX_TREE_LEVELS deep, so the stack holds at most depth - 1 nodes; should it fill up anyway,
 * WALK_EVERY at the end.  sort_always and shear: as the wide walk's (a binary walk takes a sheared ray). */
INLINE void walk_binary(const Geometry *g, Ray r, float t_min, float t_max, bool any_hit, Pass pass, bool sort_always,
                        bool shear, Hit *best, float *T, uint *visits) {
    __global const BvhNode *nodes = (__global const BvhNode *)WALK_NODES(g);
    bool by_distance = !any_hit || WALK_SORT_ANY;
    int stack[STACK_SIZE];
    float stack_t[STACK_SIZE];
    int sp = 0;
    bool overflow = false;
    float T_start = *T;
    int node = (WALK_ROOT(g) && hit_box(r, nodes, any_hit ? t_max : best->t) != INF_T) ? 0 : -1;
    while (node >= 0) {
        COUNT_NODE(visits);
        int count = nodes[node].count, offset = nodes[node].offset;
        int next = -1;
        if (count > 0) {
            WALK_LEAF(g, offset, count, false, r, t_min, t_max, any_hit, pass, best, T, visits);
            if (any_hit && *T == 0.0f) return; /* blocked: done */
        } else {
            float t_far = any_hit ? t_max : best->t;
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
            if (any_hit || stack_t[sp] <= best->t * BOX_EXIT_WIDEN) next = stack[sp];
        }
        node = next;
    }
    if (!overflow) return;
    if (any_hit) *T = T_start;
    WALK_EVERY(g, r, t_min, t_max, any_hit, pass, best, T, visits);
}
#endif

#undef walk_start
#undef walk_step
#undef walk_finish
#undef walk_wide
#undef walk_binary
#undef WALK_WIDE
#undef WALK_NODES
#undef WALK_ROOT
#undef WALK_LEAF
#undef WALK_EVERY
#undef WALK_SORT_ANY
