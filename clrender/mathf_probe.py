"""kernels/mathf.h's deterministic float32 functions run over batches on the device (kernels/mathf_probe.cl), for
tests and for docs/math.md's measured error bounds."""

from __future__ import annotations

import numpy as np

from .device import Device, get_device

PROBE = "mathf_probe.cl"
FUNCTIONS = ("sin", "cos", "exp", "log", "atan2", "acos", "asin", "pow", "floor", "sqrt")  # mathf_probe.cl's codes


def evaluate(name: str, a, b=None, device: Device | None = None) -> np.ndarray:
    """mathf.h's `name` of float32 `a` (and `b`: atan2(a, b), pow(a, b)), as float32, elementwise."""
    dev = device or get_device()
    a = np.ascontiguousarray(a, np.float32).ravel()
    b = np.zeros_like(a) if b is None else np.ascontiguousarray(np.broadcast_to(np.float32(b) if np.ndim(b) == 0 else b, a.shape), np.float32)
    out = np.empty_like(a)
    out_buf = dev.empty(out.nbytes)
    knl = dev.kernel(PROBE, "mathf_probe")
    knl(
        dev.queue,
        (max(a.size, 1),),
        None,
        n=np.int32(a.size),
        fn=np.int32(FUNCTIONS.index(name)),
        a=dev.to_device(a),
        b=dev.to_device(b),
        out=out_buf,
    )
    import pyopencl as cl

    cl.enqueue_copy(dev.queue, out, out_buf)
    return out


def lane_functions(a, b, lanes: int = 1, device: Device | None = None) -> np.ndarray:
    """(n, 5) float32: kernels/lanes.h's sincos_l (sin, cos) of `a` (|a| < 256), atan2_l(a, b), acos_l(b) and exp_l(a),
    built for `lanes` arguments a work-item (1, 8 or 16)."""
    import pyopencl as cl

    from .trace.work_layout import launch_items

    dev = device or get_device()
    a = np.ascontiguousarray(a, np.float32).ravel()
    b = np.ascontiguousarray(np.broadcast_to(np.asarray(b, np.float32), a.shape), np.float32)
    out = np.empty((a.size, 5), np.float32)
    out_buf = dev.empty(out.nbytes)
    knl = dev.kernel(PROBE, "lane_math_probe", {"LANES": lanes})
    launch_items(dev, knl, -(-a.size // lanes), n=np.int32(a.size), a=dev.to_device(a), b=dev.to_device(b), out=out_buf)
    cl.enqueue_copy(dev.queue, out, out_buf)
    return out
