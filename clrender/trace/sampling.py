"""Pixel sample positions, computed by the same kernel code the renderer uses.

Offsets are in [0, 1)^2 from the pixel's top-left corner.  Sample s of N*N
lies in sub-square row p = s // N and column q = s % N:
  uniform     the centred grid ((q + 0.5) / N, (p + 0.5) / N)
  random      N*N independent uniform positions in the pixel
  stratified  one jittered sample in each sub-square ((q + xi) / N, (p + xi') / N)
  sobol       the first N*N points of a 2-D Sobol sequence, Owen-scrambled per pixel
Random numbers come from a hash of (seed, pixel, sample, dimension).
"""

from __future__ import annotations

import numpy as np
import pyopencl as cl

from ..device import Device, get_device
from ..layout import SAMPLERS
from .tracer import global_size, trace_defines
from .work_layout import work_layout


def sample_offsets(pixels, sampler: str, n: int, seed: int = 0, device: Device | None = None) -> np.ndarray:
    """(len(pixels), n*n, 2) float32 offsets of each pixel's samples."""
    dev = device or get_device()
    pixels = np.asarray(pixels, np.int32).ravel()
    k = len(pixels)
    out = dev.empty(8 * k * n * n)
    knl = dev.kernel("trace.cl", "sample_offsets", trace_defines())  # the renderer's own build
    local = work_layout(dev.device).local_size
    knl(
        dev.queue,
        global_size(k, local),
        (local,),
        pixels=dev.to_device(pixels),
        n_work=k,
        sampler=SAMPLERS[sampler],
        samples_per_side=n,
        seed=seed,
        out=out,
    )
    result = np.empty((k, n * n, 2), np.float32)
    cl.enqueue_copy(dev.queue, result, out)
    return result


def sequence_points(pixels, samples: int, dims, seed: int = 0, first: int = 0, scrambled: bool = True, device: Device | None = None) -> np.ndarray:
    """(len(pixels), samples, len(dims)) uint32: dimensions `dims` of samples first ... first + samples - 1 of each
    pixel in the path tracer's Sobol sequence (kernels/sobol.h), as 32-bit fractions (value / 2**32); unscrambled:
    the plain 2-D Sobol coordinate dim % 2 of the sample index, the same for every pixel."""
    dev = device or get_device()
    pixels = np.asarray(pixels, np.uint32).ravel()
    dims = np.asarray(dims, np.uint32).ravel()
    k = len(pixels) * samples
    out = dev.empty(4 * k * len(dims))
    knl = dev.kernel("sobol_probe.cl", "sobol_probe")
    local = work_layout(dev.device).local_size
    knl(
        dev.queue,
        global_size(k, local),
        (local,),
        pixels=dev.to_device(pixels),
        n_samples=samples,
        first=first,
        n_work=k,
        dims=dev.to_device(dims),
        n_dims=len(dims),
        seed=seed,
        scrambled=int(scrambled),
        out=out,
    )
    result = np.empty((len(pixels), samples, len(dims)), np.uint32)
    cl.enqueue_copy(dev.queue, result, out)
    return result
