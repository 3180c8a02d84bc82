"""Arenas: several arrays in one device buffer, each region placed by its byte offset in a layout record.

A kernel that took a buffer per array would take more arguments than the contract allows (12), so the render
kernels take a few arenas instead: the Tracer's scene tables, the renderer's world, a launch's outputs.  The
offsets fill a record of layout.py (SceneTables, WorldRegions, OutRegions: one uint field per region, named as
the arrays are), and the kernel turns each into a typed pointer (kernels/common.h, REGION).

Every region starts at a multiple of `alignment(device)`: enough for any record or OpenCL vector (and for a
sub-buffer of the device, should a kernel take a region as a buffer of its own).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .errors import UsageError

MIN_ALIGN = 128  # bytes: more than any record or vector (float16) asks
MIN_REGION = 16  # bytes: an empty array still gets a region the kernels may point into


def alignment(device) -> int:
    """A region's alignment on `device` (a clrender Device): MIN_ALIGN, or the device's sub-buffer alignment."""
    return max(MIN_ALIGN, int(device.device.mem_base_addr_align) // 8)


def offsets(dtype: np.dtype, sizes: dict, align: int) -> tuple[np.ndarray, int]:
    """The regions' record (one byte offset per field of `dtype`, each region `sizes[name]` bytes) and the total size."""
    record = np.zeros((), dtype)
    at = 0
    for name in dtype.names:
        record[name] = at
        at += -(-max(int(sizes[name]), MIN_REGION) // align) * align
    if at >= 2**32:
        raise UsageError(f"{at / 2**30:.1f} GiB in one arena ({', '.join(dtype.names)}) is not allowed; allowed: below 4 GiB (32-bit offsets)")
    return record, at


@dataclass
class Arena:
    buffer: object  # the cl.Buffer
    record: np.ndarray  # the regions' byte offsets, a record of the layout dtype
    sizes: dict  # each region's bytes as given


def pack(device, dtype: np.dtype, arrays: dict) -> Arena:
    """One read-only buffer holding `arrays` (by the names of `dtype`'s fields), and where each is."""
    sizes = {name: np.asarray(arrays[name]).nbytes for name in dtype.names}
    record, total = offsets(dtype, sizes, alignment(device))
    device.check_fits(total, f"an arena of {', '.join(dtype.names)}")
    host = np.zeros(total, np.uint8)
    for name in dtype.names:
        data = np.ascontiguousarray(arrays[name]).view(np.uint8).reshape(-1)
        host[int(record[name]) : int(record[name]) + data.size] = data
    return Arena(device.to_device(host), record, sizes)
