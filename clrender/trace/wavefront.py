"""The path tracer's wavefront schedule (kernels/wavefront.cl; docs/lanes.md): the host's loop over bounces.

A launch of k pixels holds k slots, one PathState record (layout.PATH_STATE_DTYPE) each; slot i takes pixel i's
samples in order.  Each bounce runs four kernels over the slots: wave_extend (closest hits, one ray per work-item),
wave_shade (the vertex, no traversal: a kernel a driver can run in SIMD lanes), wave_occlude (shadow rays), wave_advance
(finished paths into their pixel's sums and the pixel's next sample in the same slot).  wave_advance counts the slots
still live; the loop reads the count back after every bounce, stops when it is 0, and keeps it as the lanes'
occupancy (`Wavefront.occupancy`).

`Wavefront` is called as the megakernel render_path is (Renderer.launch), with the same named buffers.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np
import pyopencl as cl

from ..layout import PATH_STATE_DTYPE

KERNELS = ("wave_start", "wave_extend", "wave_shade", "wave_occlude", "wave_advance")
SCENE_BUFFERS = ("nodes", "prims", "prim_object", "normals", "attributes", "texels", "tables", "world")


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
        self.live = device.empty(4)
        self.occupancy: list[Occupancy] = []  # one per launch
        self.seconds: dict | None = None  # a dict: each kernel's wall seconds, each launch waited for (bench/path.py)

    def __call__(self, queue, size, local, *, pixels, params, out, **scene):
        k = int(params["frame"]["n_work"])
        states = self.device.empty(k * PATH_STATE_DTYPE.itemsize)
        K = self.kernels
        K["wave_start"](queue, size, local, pixels=pixels, params=params, out=out, states=states)
        occupancy, live, count = Occupancy(k), k, np.zeros(1, np.uint32)
        buffers = {b: scene[b] for b in SCENE_BUFFERS}
        while live:
            occupancy.live.append(live)
            for name in ("wave_extend", "wave_shade", "wave_occlude"):
                self._timed(queue, name, lambda name=name: K[name](queue, size, local, **buffers, params=params, states=states))
            cl.enqueue_fill_buffer(queue, self.live, np.uint32(0), 0, 4)
            self._timed(queue, "wave_advance", lambda: K["wave_advance"](queue, size, local, params=params, out=out, states=states, live=self.live))
            cl.enqueue_copy(queue, count, self.live)
            live = int(count[0])
        self.occupancy.append(occupancy)

    def _timed(self, queue, name: str, launch) -> None:
        """Launch; with `seconds` set (a dict), wait for the kernel and add its wall seconds under its name."""
        if self.seconds is None:
            launch()
            return
        start = time.perf_counter()
        launch()
        queue.finish()
        self.seconds[name] = self.seconds.get(name, 0.0) + time.perf_counter() - start
