"""A Tracer's ray queries reuse their buffers from call to call (clrender/trace/ray_buffers.py): calls of
growing and shrinking sizes, alternating closest-hit and any-hit queries, answer bit for bit as the
same call on a fresh Tracer does; answers already returned are not touched by later calls; bad rays
are still refused with the one-line message, and the next call still works; calls from several threads
at once answer as one after another."""

from concurrent.futures import ThreadPoolExecutor
from types import SimpleNamespace

import numpy as np
import pytest

from clrender.errors import UsageError
from clrender.scene.meshes import dense_mesh
from clrender.trace import ray_buffers
from clrender.trace.tracer import Tracer

MESH = dense_mesh(2000, seed=3)


def rays(n: int, seed: int):
    """n rays from a sphere of radius 3 around the mesh toward points near its centre, with their
    distances to those points (about half of the segments end before the surface)."""
    rng = np.random.default_rng(seed)
    o = rng.normal(size=(n, 3))
    o *= 3 / np.linalg.norm(o, axis=1, keepdims=True)
    d = rng.normal(scale=0.3, size=(n, 3)) - o
    return o, d, rng.uniform(0.3, 1.0, n)


def answers(tracer, o, d, t_far):
    """Every output of one closest-hit and one any-hit query, visits included."""
    t, prim, obj = tracer.intersect(o, d, t_min=0.01 * t_far)
    visits = tracer.last_visits.copy()
    blocked = tracer.occluded(o, d, t_far)
    return t, prim, obj, visits, blocked, tracer.last_visits.copy()


@pytest.fixture(scope="module")
def tracer(device):
    return Tracer(MESH, device=device)


def fresh(device):
    return Tracer(MESH, device=device)


def assert_same(got, want):
    for g, w in zip(got, want, strict=True):
        np.testing.assert_array_equal(g, w)
        assert g.dtype == w.dtype and g.shape == w.shape


@pytest.mark.parametrize("sizes", [(3000, 17, 5000, 1, 0, 2500), (1, 1025, 4096, 8)], ids=["grow-and-shrink", "at-the-capacities"])
def test_calls_of_changing_sizes_answer_as_on_a_fresh_tracer(device, sizes):
    tracer = fresh(device)  # its own: the capacity it ends with depends on its calls alone
    for k, n in enumerate(sizes):
        o, d, t_far = rays(n, seed=k)
        assert_same(answers(tracer, o, d, t_far), answers(fresh(device), o, d, t_far))
    largest = 1 << (max(sizes) - 1).bit_length()  # grown to the next power of two of the largest call, kept
    assert tracer._ray_buffers["intersect"].kept[0].capacity == largest


def test_answers_already_returned_are_not_changed_by_later_calls(tracer):
    o, d, t_far = rays(3000, seed=11)
    first = answers(tracer, o, d, t_far)
    kept = [a.copy() for a in first]
    answers(tracer, *rays(3000, seed=12))
    assert_same(first, kept)


def test_a_call_past_the_kept_size_gets_buffers_of_its_own(device, monkeypatch):
    monkeypatch.setattr(ray_buffers, "KEEP_RAYS", 1500)
    tracer = fresh(device)
    small, large = rays(100, seed=1), rays(2000, seed=2)
    got_small = answers(tracer, *small)
    got_large = answers(tracer, *large)
    assert tracer._ray_buffers["intersect"].kept is None  # dropped after the large call
    assert_same(answers(tracer, *small), got_small)
    monkeypatch.setattr(ray_buffers, "KEEP_RAYS", 1 << 21)
    assert_same(answers(fresh(device), *large), got_large)


def test_fields_too_large_for_one_allocation_get_one_buffer_each(device, tracer):
    """A device whose largest allocation cannot hold the fields together: one buffer a field."""
    real = device.device
    small = SimpleNamespace(mem_base_addr_align=real.mem_base_addr_align, max_mem_alloc_size=20 * 1024)
    shim = SimpleNamespace(context=device.context, device=small)
    split = Tracer(MESH, device=device)
    for buffers in split._ray_buffers.values():
        buffers.device = shim
    o, d, t_far = rays(3000, seed=5)  # capacity 4096: 16 KiB for t_min alone
    assert_same(answers(split, o, d, t_far), answers(tracer, o, d, t_far))
    inputs, outputs = split._ray_buffers["occluded"].kept
    assert len(inputs.groups) == 4 and len(outputs.groups) == 2


@pytest.mark.parametrize(
    "bad, where",
    [
        ((slice(None), [[0.0, 0, 1], [0.0, 0, 0]]), r"ray 1 has origin \(0.0, 0.0, 0.0\) and direction \(0.0, 0.0, 0.0\)"),
        ((slice(None), [[0.0, 0, 1], [-0.0, 0, -0.0]]), r"ray 1 has origin \(0.0, 0.0, 0.0\) and direction \(-0.0, 0.0, -0.0\)"),
        (([[0.0, 0, 0], [np.nan, 0, 0]], [[0.0, 0, 1], [0.0, 0, 1]]), r"ray 1 has origin \(nan, 0.0, 0.0\)"),
        (([[0.0, 0, 0], [0.0, 0, 0]], [[0.0, 0, 1], [0.0, 1e39, 1]]), r"ray 1 has origin \(0.0, 0.0, 0.0\) and direction \(0.0, inf, 1.0\)"),
    ],
    ids=["zero", "minus-zero", "nan-origin", "past-float32"],
)
def test_bad_rays_are_refused_in_one_line_and_the_next_call_works(tracer, bad, where):
    o, d = bad
    if isinstance(o, slice):
        o = np.zeros((2, 3))
    message = r"^ray origins and directions must be finite, and directions nonzero; " + where
    good = rays(50, seed=3)
    before = answers(tracer, *good)
    for query in (lambda: tracer.intersect(o, d), lambda: tracer.occluded(o, d, 1.0)):
        with pytest.raises(UsageError, match=message):
            query()
    assert_same(answers(tracer, *good), before)


def test_a_bad_ray_is_named_by_its_index_in_the_rays_shape(tracer):
    d = np.tile([0.0, 0.0, -1.0], (2, 3, 1))
    d[1, 2] = 0.0
    with pytest.raises(UsageError, match=r"ray \(1, 2\) has origin \(0.0, 0.0, 0.0\) and direction \(0.0, 0.0, 0.0\)"):
        tracer.intersect([0.0, 0.0, 0.0], d)


def test_a_direction_whose_square_underflows_is_not_zero(tracer):
    # 1e-30 squared is 0 in float32: the bits, not a float32 dot product, decide
    t, _, _ = tracer.intersect([[0.0, 0.0, 3.0]], [[0.0, 0.0, -1e-30]])
    assert np.isfinite(t).all() and t[0] > 1e29


def test_rays_checked_before_distances(tracer):
    with pytest.raises(UsageError, match="directions nonzero"):
        tracer.occluded([[0.0, 0, 0]], [[0.0, 0, 0]], t_max=np.nan)
    with pytest.raises(UsageError, match="t_max must not be NaN"):
        tracer.occluded([[0.0, 0, 0]], [[0.0, 0, 1]], t_max=np.nan)


def test_calls_from_several_threads_answer_as_one_after_another(tracer):
    sets = [rays(700 + 300 * k, seed=20 + k) for k in range(6)]
    serial = [answers(tracer, *s)[:3] for s in sets]
    with ThreadPoolExecutor(4) as pool:
        parallel = list(pool.map(lambda s: tracer.intersect(s[0], s[1], t_min=0.01 * s[2]), sets * 2))
    for got, want in zip(parallel, serial * 2):
        assert_same(got, want)


def test_two_tracers_taking_turns_answer_each_for_its_own_scene(device, tracer):
    """Each Tracer launches a kernel copy of its own (launch.BoundKernel): the scene set on one is not
    the other's, though both are built from the same program."""
    other = Tracer(dense_mesh(1500, seed=8), device=device)
    o, d, t_far = rays(400, seed=30)
    want = answers(tracer, o, d, t_far), answers(other, o, d, t_far)
    for _ in range(2):
        assert_same(answers(tracer, o, d, t_far), want[0])
        assert_same(answers(other, o, d, t_far), want[1])
    assert not np.array_equal(want[0][1], want[1][1])  # the two scenes answer differently
