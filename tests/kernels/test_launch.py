"""Kernels are called by their parameters' names (clrender/launch.py): the names and types come from the
`__kernel` signature in the source, so a launch that misnames, omits or mistypes an argument is refused
before anything is enqueued, and a correct one reaches the right parameters whatever order it names them in."""

import numpy as np
import pyopencl as cl
import pytest

from clrender import layout
from clrender.launch import Kernel, kernel_signatures

SOURCE = """
/* a comment with __kernel void decoy(int x) inside */
__kernel void axpy(int n, float a, __global const float *x, __global float *y, uint tag) {
    int i = get_global_id(0);
    if (i < n) y[i] = a * x[i] + y[i] + (float)tag;
}
__kernel void material_ior(Material m, __global float *out) { out[0] = m.ior; out[1] = m.kd[2]; }
"""


@pytest.fixture(scope="module")
def kernels(device):
    program = device.build(SOURCE, "launch test")
    signatures = kernel_signatures(SOURCE)
    return {name: Kernel(getattr(program, name), params) for name, params in signatures.items()}


def test_the_signature_is_read_from_the_source_comments_ignored():
    params = kernel_signatures(SOURCE)
    assert list(params) == ["axpy", "material_ior"]
    assert [(p.name, p.type, p.pointer) for p in params["axpy"]] == [
        ("n", "int", False),
        ("a", "float", False),
        ("x", "float", True),
        ("y", "float", True),
        ("tag", "uint", False),
    ]


def test_named_arguments_reach_their_parameters_in_any_order(device, kernels):
    x, y = np.arange(4, dtype=np.float32), np.ones(4, np.float32)
    y_buf = device.to_device(y, writable=True)
    kernels["axpy"](device.queue, (4,), None, y=y_buf, tag=10, x=device.to_device(x), a=2.0, n=4)
    cl.enqueue_copy(device.queue, y, y_buf)
    np.testing.assert_array_equal(y, 2 * np.arange(4) + 1 + 10)


def test_a_record_travels_by_value(device, kernels):
    m = np.zeros((), layout.MATERIAL_DTYPE)
    m["ior"], m["kd"] = 1.5, (0.1, 0.2, 0.3)
    out = np.zeros(2, np.float32)
    buf = device.empty(out.nbytes)
    kernels["material_ior"](device.queue, (1,), None, m=m, out=buf)
    cl.enqueue_copy(device.queue, out, buf)
    assert out.tolist() == [np.float32(1.5), np.float32(0.3)]


@pytest.mark.parametrize(
    "change, message",
    [
        ({"n": None}, "missing \\['n'\\]"),
        ({"z": 1}, "unknown \\['z'\\]"),
        ({"x": np.zeros(4, np.float32)}, "argument x .* must be a buffer"),
        ({"n": 2.0}, "argument n .* must be an integer"),
        ({"a": "2"}, "argument a .* must be a real number"),
        ({"tag": -1}, "argument tag .*: -1 does not fit"),
        ({"n": 2**31}, "does not fit"),
    ],
)
def test_a_wrong_launch_is_refused_naming_the_argument(device, kernels, change, message):
    args = {"n": 4, "a": 1.0, "x": device.empty(16), "y": device.empty(16), "tag": 0, **change}
    args = {k: v for k, v in args.items() if v is not None}
    with pytest.raises(TypeError, match=message):
        kernels["axpy"](device.queue, (4,), None, **args)


def test_a_record_argument_must_have_the_records_dtype(device, kernels):
    with pytest.raises(TypeError, match="argument m .* one record"):
        kernels["material_ior"](device.queue, (1,), None, m=np.zeros((), layout.OBJECT_DTYPE), out=device.empty(8))


def test_a_signature_that_disagrees_with_the_driver_is_refused(device, kernels):
    with pytest.raises(RuntimeError, match="reports 5 arguments, its source declares 4"):
        Kernel(kernels["axpy"].kernel, kernel_signatures(SOURCE)["axpy"][:4])


def test_a_bound_kernel_keeps_its_arguments_between_launches(device, kernels):
    """knl.bound(): arguments set by name stay set; a launch changes only what it names; the shared
    kernel's arguments are not touched (a launch through it in between does not change the bound one's)."""
    bound = kernels["axpy"].bound()
    x = device.to_device(np.arange(4, dtype=np.float32))
    y = np.zeros(4, np.float32)
    y_buf = device.to_device(y, writable=True)
    bound.set(n=4, a=2.0, x=x, y=y_buf, tag=0)
    bound.enqueue(device.queue, (4,), None)
    other = device.to_device(np.zeros(4, np.float32), writable=True)
    kernels["axpy"](device.queue, (4,), None, n=4, a=100.0, x=x, y=other, tag=7)
    bound.set(tag=1, n=3)  # the rest as before
    bound.enqueue(device.queue, (4,), None)
    cl.enqueue_copy(device.queue, y, y_buf)
    np.testing.assert_array_equal(y, [0 * 4 + 1, 2 * 2 + 1, 4 * 2 + 1, 6])  # the fourth outside n=3 the second time


def test_a_bound_kernel_refuses_what_a_launch_refuses(device, kernels):
    bound = kernels["axpy"].bound()
    with pytest.raises(TypeError, match=r"unknown \['alpha'\]"):
        bound.set(alpha=2.0)
    with pytest.raises(TypeError, match="argument x .*must be a buffer"):
        bound.set(x=np.zeros(4, np.float32))
    bound.set(n=4, a=2.0)
    with pytest.raises(TypeError, match=r"missing \['x', 'y', 'tag'\]"):
        bound.enqueue(device.queue, (4,), None)
