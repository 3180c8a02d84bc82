"""The path tracer's lane schedule (kernels/path.cl render_path_lanes; docs/lanes.md): render_path's pixels LANES a
work-item, each pixel's paths in one lane of a vector register, its shading written once over kernels/lanes.h's lane
type (the megakernel runs the same source at width 1), the walks a lane at a time.  The images are the megakernel's
bits.  `LaneKernel` is called as the megakernel render_path is (Renderer.launch), with the same named buffers.

What the lanes do not take renders with the megakernel (`falls_back` says why): a scene without primitives, and devices
that are not CPUs."""

from __future__ import annotations

import pyopencl as cl

from .work_layout import global_size

KERNEL = ("path.cl", "render_path_lanes")


def lane_width(device: cl.Device) -> int:
    """Paths a work-item: 16 on a CPU whose OpenCL driver prefers 16-float vectors (AVX-512), 8 on other CPUs, 0 (the
    megakernel) on other devices, where a work-item is one path, and on the Oclgrind simulator."""
    if not device.type & cl.device_type.CPU or "oclgrind" in device.platform.name.lower():
        return 0  # a GPU's work-item is one path; Oclgrind checks the megakernel (its lanes: test_oclgrind's own case)
    return 16 if device.preferred_vector_width_float >= 16 else 8


def falls_back(defines: dict, n_prims: int, device: cl.Device) -> str:
    """Why a render under --path-schedule lanes takes the megakernel, or ""."""
    if n_prims == 0 and not defines.get("INSTANCED"):  # n_prims counts the flat part's
        return "a scene without primitives"
    if not lane_width(device):
        return "a device that is not a CPU, or the Oclgrind simulator (one path a work-item is its lanes)"
    return ""


def lanes_of(defines: dict, n_prims: int, device: cl.Device) -> int:
    """The lanes a render of this build takes under --path-schedule lanes: lane_width, or 0 where it falls back."""
    return 0 if falls_back(defines, n_prims, device) else lane_width(device)


class LaneKernel:
    """render_path_lanes for one build (the megakernel's defines, LANES paths a work-item)."""

    def __init__(self, device, defines: dict, lanes: int):
        self.lanes = lanes
        self.kernel = device.kernel(*KERNEL, {**defines, "LANES": lanes})

    def __call__(self, queue, size, local, *, params, **args):
        items = -(-int(params["frame"]["n_work"]) // self.lanes)
        return self.kernel(queue, global_size(items, local[0]), local, params=params, **args)
