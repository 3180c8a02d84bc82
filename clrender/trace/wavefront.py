"""The path tracer's wavefront schedule (kernels/wavefront.cl; docs/lanes.md): the host's loop over bounces.

A launch of k pixels holds k slots, one PathState record (layout.PATH_STATE_DTYPE) each; slot i takes pixel i's
samples in order.  Each bounce runs four kernels over the slots: wave_extend (closest hits, one ray per work-item),
wave_shade (the vertex, no traversal: the driver runs it in SIMD lanes), wave_occlude (shadow rays), wave_advance
(finished paths into their pixel's sums and the pixel's next sample in the same slot).  wave_advance counts the slots
still live and queues them for the next bounce; the loop reads the count back after every bounce, launches the next
bounce's kernels over that many work-items (each takes its slot from the queue), stops when it is 0, and keeps it as
the lanes' occupancy (`Wavefront.occupancy`).

`Wavefront` is called as the megakernel render_path is (Renderer.launch), with the same named buffers.
"""

from __future__ import annotations

import itertools
import time
from dataclasses import dataclass, field

import numpy as np
import pyopencl as cl

from ..layout import PATH_STATE_DTYPE
from .work_layout import global_size

READ_EVERY = 4  # bounces between reads of the live count: the kernels queued meanwhile keep the device busy
KERNELS = ("wave_start", "wave_extend", "wave_shade", "wave_occlude", "wave_advance")
SCENE_BUFFERS = ("nodes", "prims", "prim_object", "normals", "attributes", "texels", "tables", "world")


def falls_back(defines: dict) -> str:
    """Why a render kernel build (its -D defines) takes the megakernel under --path-schedule wavefront, or ""."""
    if defines.get("ALPHA_TEST") and defines.get("PATH_SAMPLER", 0) == 0:
        return "stochastic alpha under the independent sampler: its shadow rays draw before the BSDF's sample"
    return ""


@dataclass
class Occupancy:
    """Live paths per bounce of one launch: lanes busy is live / slots."""

    slots: int
    live: list = field(default_factory=list)  # slots live at the start of each bounce

    @property
    def mean(self) -> float:
        """Busy lanes over all bounces: the sum of live over bounces x slots."""
        return sum(self.live) / (len(self.live) * self.slots) if self.live else 0.0


class Wavefront:
    """The wavefront schedule's kernels for one build (kernels/wavefront.cl with the megakernel's defines)."""

    def __init__(self, device, defines: dict):
        self.device = device
        self.kernels = {name: device.kernel("wavefront.cl", name, defines) for name in KERNELS}
        self.occupancy: list[Occupancy] = []  # one per launch
        self.seconds: dict | None = None  # a dict: each kernel's wall seconds, each launch waited for (bench/path.py)

    def __call__(self, queue, size, local, *, pixels, params, out, **scene):
        k = int(params["frame"]["n_work"])
        states = self.device.empty(k * PATH_STATE_DTYPE.itemsize)
        lists = [self.device.empty(4 * (k + 1)) for _ in range(2)]  # the live slots (a count, then the slots) and the next
        self._launch(queue, "wave_start", size, local, pixels=pixels, params=params, out=out, states=states, slots=lists[0])
        occupancy, live, count = Occupancy(k), k, np.zeros(1, np.uint32)
        buffers = {b: scene[b] for b in SCENE_BUFFERS}
        for bounce in itertools.count():
            if bounce % READ_EVERY == 0:  # the count: the lanes' occupancy, the launch size, the stop
                cl.enqueue_copy(queue, count, lists[bounce % 2])
                live = int(count[0])
                if not live:
                    break
            occupancy.live.append(live)  # an upper bound between reads
            size, slots, next_slots = global_size(live, local[0]), lists[bounce % 2], lists[1 - bounce % 2]
            for name in ("wave_extend", "wave_shade", "wave_occlude"):
                self._launch(queue, name, size, local, **buffers, params=params, states=states, slots=slots)
            cl.enqueue_fill_buffer(queue, next_slots, np.uint32(0), 0, 4)
            self._launch(queue, "wave_advance", size, local, params=params, out=out, states=states, slots=slots, next_slots=next_slots)
        self.occupancy.append(occupancy)

    def _launch(self, queue, name: str, size, local, **args) -> None:
        """Kernel `name` over `size`; with `seconds` set (a dict), waited for and its wall seconds added under its name."""
        start = time.perf_counter()
        self.kernels[name](queue, size, local, **args)
        if self.seconds is not None:
            queue.finish()
            self.seconds[name] = self.seconds.get(name, 0.0) + time.perf_counter() - start
