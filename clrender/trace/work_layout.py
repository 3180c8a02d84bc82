"""How trace.cl's launches map rays to work-items and work-groups, chosen from what the device reports.

The same kernels give the same bits with any layout (every ray's walk is the same float operations;
tests/trace/test_work_layout.py); what changes is speed, and it changes per driver (docs/bvh.md,
"Across drivers"):
- PoCL on a CPU compiles a work-group into loops over its work-items and runs the explicit vectors
  our kernels write (float8 ray packets, a node's children in float4/float8 lanes) as they are; it
  asks for explicit vectors (preferred float vector width 16) and runs 64-item groups best.
- Intel's OpenCL CPU runtime compiles for an implicit vectoriser that maps work-items to SIMD lanes,
  and says so by asking for scalar code (preferred float vector width 1).  On these kernels groups
  of 64 ran 10x slower there than groups of 8 (groups of 1 or 4: as fast as 8); switching its
  vectoriser off did not help, and it reports 229 KiB of private memory for intersect_rays (PoCL:
  1 KiB): a group's private state side by side, far past the caches at 64 items.  It gets groups of 8.
- A GPU maps work-items to SIMD lanes in hardware: one ray per work-item (the single-ray walk), 64
  work-items a group (two NVIDIA warps, one AMD wavefront); a float8 packet per work-item would
  hold eight rays' state in one lane's registers and spill.
$CLRENDER_WORK_LAYOUT ("RAYS_PER_ITEM:LOCAL_SIZE", e.g. "1:64") overrides the choice, for measuring.
"""

from __future__ import annotations

import os
from dataclasses import dataclass

import numpy as np

from ..errors import UsageError

RAYS_PER_ITEM_CHOICES = (8, 1)  # kernels/trace.cl takes a float8 packet's worth of rays, or one ray
ENV = "CLRENDER_WORK_LAYOUT"


@dataclass(frozen=True)
class WorkLayout:
    # ray queries per work-item of intersect_rays / occluded_rays: 8 (walked as a packet when
    # they go the same way) or 1 (each work-item walks its one ray)
    rays_per_item: int = 8
    # work-items per work-group of every trace.cl launch; fixed per device, since PoCL builds a
    # work-group function per local size and letting it choose (global sizes change) recompiles
    local_size: int = 64
    why: str = "PoCL's CPU device: explicit vectors, 64-item groups (measured)"


POCL = WorkLayout()
SCALAR_CPU = WorkLayout(8, 8, "a CPU driver that vectorises across work-items (preferred float vector width 1): 8-item groups, 10x faster than 64")
GPU = WorkLayout(1, 64, "a GPU: one ray per work-item, 64-item groups (two warps, one wavefront)")


def parse(text: str) -> WorkLayout:
    """A layout from "RAYS_PER_ITEM:LOCAL_SIZE", or UsageError naming what is allowed."""
    try:
        rays, local = (int(part) for part in text.split(":"))
    except ValueError:
        rays = local = 0
    if rays not in RAYS_PER_ITEM_CHOICES or not 1 <= local <= 1024:
        raise UsageError(f"{ENV}={text!r} is not allowed; allowed: RAYS_PER_ITEM:LOCAL_SIZE, rays 8 or 1, local size 1 to 1024")
    return WorkLayout(rays, local, f"${ENV}")


def choose(device_type: int, preferred_float_width: int, max_work_group_size: int) -> WorkLayout:
    """The layout for a device from what it reports (cl.device_type bits, CL_DEVICE_PREFERRED_VECTOR_WIDTH_FLOAT,
    CL_DEVICE_MAX_WORK_GROUP_SIZE)."""
    gpu_bit = 4  # CL_DEVICE_TYPE_GPU
    if device_type & gpu_bit:
        layout = GPU
    elif preferred_float_width <= 1:
        layout = SCALAR_CPU
    else:
        layout = POCL
    local = min(layout.local_size, max_work_group_size)
    return layout if local == layout.local_size else WorkLayout(layout.rays_per_item, local, layout.why + f", at most {local}")


def work_layout(cl_device) -> WorkLayout:
    """The layout for a pyopencl device ($CLRENDER_WORK_LAYOUT first)."""
    if os.environ.get(ENV):
        return parse(os.environ[ENV])
    return choose(int(cl_device.type), int(cl_device.preferred_vector_width_float), int(cl_device.max_work_group_size))


def global_size(n: int, local_size: int) -> tuple:
    """n work-items rounded up to whole work-groups (the kernels skip the extra ones)."""
    return (max(-(-n // local_size), 1) * local_size,)


def launch_items(dev, kernel, items: int, /, **args) -> None:
    """Run `kernel` over `items` work-items in groups of the device's local size (work_layout), its arguments by name."""
    local = work_layout(dev.device).local_size
    kernel(dev.queue, global_size(items, local), (local,), **args)


def read_items(dev, kernel, items: int, shape, dtype, /, **args) -> np.ndarray:
    """launch_items with a new buffer as the kernel's `out`, read back as an array of `shape` and `dtype`."""
    import pyopencl as cl

    host = np.empty(shape, dtype)
    out = dev.empty(host.nbytes)
    launch_items(dev, kernel, items, **args, out=out)
    cl.enqueue_copy(dev.queue, host, out)
    return host
