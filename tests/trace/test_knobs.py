"""Trace knobs (clrender/trace/knobs.py): the sizes a Tracer is built with are values passed to it,
so one Tracer's small stacks never reach another, whatever order the tests run in."""

import numpy as np
import pytest

from clrender.errors import UsageError
from clrender.trace.knobs import DEFAULT_KNOBS, TraceKnobs
from clrender.trace.tracer import Tracer, trace_defines


def test_the_default_stacks_hold_every_tree_the_builders_make():
    """Near-first closest-hit traversal keeps at most depth - 1 far nodes and any-hit traversal at
    most depth; a wide node adds width - 1 pending siblings per level plus its own lanes."""
    levels = DEFAULT_KNOBS.max_tree_levels
    assert DEFAULT_KNOBS.stack_size >= levels
    for width in (4, 8):
        assert DEFAULT_KNOBS.wide_stack_size(width) >= (width - 1) * (levels - 1) + width
    assert DEFAULT_KNOBS.stacks_hold_every_tree
    assert not TraceKnobs(stack_size=2).stacks_hold_every_tree


def test_a_tracer_builds_its_kernels_with_its_own_knobs(device):
    mesh = (np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0]]), np.array([[0, 1, 2]]))
    small = Tracer(mesh, device=device, knobs=TraceKnobs(stack_size=2, shaft_candidates=1))
    default = Tracer(mesh, device=device)
    assert small.defines["STACK_SIZE"] == 2 and small.defines["WIDE_STACK_SIZE"] == 8
    assert small.defines["SHAFT_CANDIDATES"] == 1
    assert default.defines == trace_defines()  # the small one changed nothing shared
    assert default.defines["STACK_SIZE"] == DEFAULT_KNOBS.stack_size


def test_the_build_keeps_the_tracers_depth_cap(device):
    """Boxes at 16^i make binned SAH peel one primitive per level unless the cap stops it."""
    x = 16.0 ** np.arange(31)
    v = np.repeat(np.stack([x, 0 * x, 0 * x], axis=1), 3, axis=0) + np.tile(np.eye(3), (31, 1))
    mesh = (v, np.arange(len(v)).reshape(-1, 3))
    capped = Tracer(mesh, device=device, knobs=TraceKnobs(max_tree_levels=8, max_leaf_size=1))
    assert capped.bvh.depth <= 8


@pytest.mark.parametrize(
    "bad",
    [dict(stack_size=0), dict(stack_size=2.5), dict(max_tree_levels=1), dict(max_tree_levels=65), dict(shaft_candidates=True), dict(max_leaf_size=0)],
)
def test_knobs_out_of_range_are_refused_with_the_allowed_range(bad):
    ((name, value),) = bad.items()
    with pytest.raises(UsageError, match=f"{name} = {value!r}; allowed: an integer from"):
        TraceKnobs(**bad)


def test_a_tracer_refuses_knobs_of_another_type():
    with pytest.raises(UsageError, match="TraceKnobs"):
        Tracer((np.eye(3), np.array([[0, 1, 2]])), knobs={"stack_size": 2})
