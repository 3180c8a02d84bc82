"""The fixed sizes a Tracer's kernels and its BVH are made with: one frozen value, passed in.

Every size here becomes a -D value of the Tracer's kernel build or an argument of its BVH build.
Nothing reads a module global at build time, so a caller (a test forcing the kernels' stack
overflow fallback, say) passes smaller knobs to one Tracer and every other Tracer keeps the
defaults, whatever ran before.

    tracer = Tracer(mesh, knobs=TraceKnobs(stack_size=2))  # stacks overflow: every primitive is tested
"""

from __future__ import annotations

from dataclasses import dataclass

from ..errors import UsageError, value_shown

# Primitives per binary leaf for each traversal width.  The wide layouts test a leaf's triangles four
# at a time (leaf blocks, bvh_wide.kernel_rows), so bigger leaves pay there: under 8-wide nodes leaves
# of at most 6 traced 10-20% faster than 2 (docs/bvh.md; 3-6% on the dense 100k mesh in 2026-11, once large
# primitives got leaves of their own: clrender.trace.bvh.LARGE_SHARE).
BEST_LEAF_SIZE = {2: 4, 4: 6, 8: 6}
# The SAH build keeps this many pending nodes per build_subtree work-item (-DBUILD_STACK): a subtree
# grown depth-first holds at most its depth plus the two children just split, and trees are at most
# MAX_TREE_LEVELS_LIMIT deep.
BUILD_STACK = 66
MAX_TREE_LEVELS_LIMIT = BUILD_STACK - 2


@dataclass(frozen=True)
class TraceKnobs:
    # binary traversal stack entries (-DSTACK_SIZE); near-first closest-hit traversal keeps at most
    # depth - 1 far nodes and any-hit traversal at most depth, so it holds any tree of max_tree_levels
    # (smaller only to test the kernels' fallback: should a stack fill up, every primitive is tested)
    stack_size: int = 64
    # deepest tree the builders make, root included: SAH nodes switch to halving early enough
    max_tree_levels: int = 48
    # leaf blocks a shadow shaft may collect before its rays walk the tree one by one (kernels/shaft.h)
    shaft_candidates: int = 16
    # primitives per binary leaf; None: the traversal width's best (BEST_LEAF_SIZE)
    max_leaf_size: int | None = None

    def __post_init__(self):
        for name, low, high in (
            ("stack_size", 1, 1024),
            ("max_tree_levels", 2, MAX_TREE_LEVELS_LIMIT),
            ("shaft_candidates", 1, 1024),
            ("max_leaf_size", 1, 2**28),
        ):
            value = getattr(self, name)
            if value is None and name == "max_leaf_size":
                continue
            if isinstance(value, bool) or not isinstance(value, int) or not low <= value <= high:
                raise UsageError(f"trace knob {name} = {value_shown(value)}; allowed: an integer from {low} to {high}")

    def leaf_size(self, width: int) -> int:
        return self.max_leaf_size if self.max_leaf_size is not None else BEST_LEAF_SIZE[width]

    def wide_stack_size(self, width: int) -> int:
        """Traversal stack entries for a tree of `width`-wide nodes (-DWIDE_STACK_SIZE).  A tree of at
        most L levels needs (width - 1) * (L - 1) + width: along the path to the current node at most
        width - 1 pending siblings per level, plus one node's lanes.  Scaled from the binary stack, so
        that shrinking it shrinks this one too."""
        return (width - 1) * (self.stack_size - 1) + 1

    @property
    def stacks_hold_every_tree(self) -> bool:
        """True when no traversal stack can overflow on a tree the builders make (the defaults)."""
        levels = self.max_tree_levels
        return self.stack_size >= levels and all(self.wide_stack_size(w) >= (w - 1) * (levels - 1) + w for w in (4, 8))


DEFAULT_KNOBS = TraceKnobs()
