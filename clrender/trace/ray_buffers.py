"""The buffers a Tracer's ray queries reuse from call to call (docs/python-api.md).

A query's rays are written into one input buffer and its answers read from one output buffer, each
a single OpenCL buffer cut into sub-buffers, one per kernel argument (origins, directions, t_min, ...),
kept by the Tracer and grown (never shrunk) to the largest call so far.  Per call the host maps each
buffer once: the input one to write the rays into it as float32 (the conversion, broadcast and copy
in one numpy assignment), the output one to copy the answers out into fresh arrays.  The buffers are
ALLOC_HOST_PTR, so on a CPU device the kernels read and write the very memory the host maps (no copy
by the driver), and on any device there are four queue commands per call besides the kernel.

Fresh buffers per call cost a 512^2 query more than its rays' validation: new pages faulted in on
every upload, and a map or copy per output array.
"""

from __future__ import annotations

import contextlib
from dataclasses import dataclass

import numpy as np
import pyopencl as cl

from ..device import Device

# rays a Tracer keeps buffers for between calls (44 bytes a ray: 88 MiB); a larger call gets its own, freed after
KEEP_RAYS = 1 << 21
MIN_RAYS = 1024  # smallest capacity: small calls of different sizes share one set of buffers

# name in the kernel's signature, dtype, values per ray
INTERSECT_IN = (("origins", np.float32, 3), ("directions", np.float32, 3), ("t_min", np.float32, 1))
INTERSECT_OUT = (("t_out", np.float32, 1), ("prim_out", np.int32, 1), ("object_out", np.int32, 1), ("visits_out", np.uint32, 1))
OCCLUDED_IN = (*INTERSECT_IN, ("t_max", np.float32, 1))
OCCLUDED_OUT = (("occluded_out", np.int32, 1), ("visits_out", np.uint32, 1))


@dataclass(frozen=True)
class Field:
    name: str
    dtype: np.dtype
    width: int  # values per ray
    offset: int  # bytes from the start of its group's buffer


class Block:
    """Arrays `fields` for `capacity` rays in OpenCL buffers: one buffer when they fit in one allocation,
    else one per field; `args` are the sub-buffers the kernel takes, by parameter name."""

    def __init__(self, device: Device, fields, capacity: int, flags):
        self.capacity = capacity
        align = max(4096, device.device.mem_base_addr_align // 8)  # a sub-buffer starts at a multiple

        def padded(size: int) -> int:
            return -(-size // align) * align

        sizes = [capacity * np.dtype(dtype).itemsize * width for _, dtype, width in fields]
        one = sum(map(padded, sizes)) <= device.device.max_mem_alloc_size
        self.groups: list[tuple[cl.Buffer, int, list[Field]]] = []  # (buffer, bytes, its fields)
        self.args: dict[str, cl.Buffer] = {}
        grouped = [list(zip(fields, sizes))] if one else [[(f, s)] for f, s in zip(fields, sizes)]
        for group in grouped:
            nbytes = sum(padded(size) for _, size in group)
            buffer = cl.Buffer(device.context, flags | cl.mem_flags.ALLOC_HOST_PTR, size=nbytes)
            placed, offset = [], 0
            for (name, dtype, width), size in group:
                placed.append(Field(name, np.dtype(dtype), width, offset))
                region = buffer if len(group) == 1 else buffer.get_sub_region(offset, size, flags)
                self.args[name] = region
                offset += padded(size)
            self.groups.append((buffer, nbytes, placed))

    @contextlib.contextmanager
    def mapped(self, queue: cl.CommandQueue, n: int, flags):
        """Host arrays of the first n rays of every field, by name ((n, width), or (n,) for one value a ray),
        valid inside the `with` (unmapped after it, also on an exception)."""
        maps, views = [], {}
        try:
            for buffer, nbytes, placed in self.groups:
                raw, _ = cl.enqueue_map_buffer(queue, buffer, flags, 0, (nbytes,), np.uint8, is_blocking=True)
                maps.append(raw)
                for f in placed:
                    size = n * f.dtype.itemsize * f.width
                    view = raw[f.offset : f.offset + size].view(f.dtype)
                    views[f.name] = view.reshape(n, f.width) if f.width > 1 else view
            yield views
        finally:
            for raw in maps:
                raw.base.release(queue)


class RayBuffers:
    """A Tracer's input and output Blocks for one kind of query, grown to the largest call so far."""

    def __init__(self, device: Device, inputs, outputs):
        self.device, self.inputs, self.outputs = device, inputs, outputs
        self.kept: tuple[Block, Block] | None = None

    def blocks(self, n: int) -> tuple[Block, Block]:
        """(input Block, output Block) for n rays: the kept ones, grown if too small; a call over KEEP_RAYS
        gets blocks of its own, dropped after it."""
        if self.kept is not None and self.kept[0].capacity >= n:
            return self.kept
        capacity = max(MIN_RAYS, 1 << max(n - 1, 0).bit_length())  # the next power of two: few regrowths
        if n > KEEP_RAYS:
            capacity = n
        self.kept = None  # the old buffers go before the new ones are made
        mf = cl.mem_flags
        made = Block(self.device, self.inputs, capacity, mf.READ_ONLY), Block(self.device, self.outputs, capacity, mf.WRITE_ONLY)
        if n <= KEEP_RAYS:
            self.kept = made
        return made
