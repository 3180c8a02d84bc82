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

from ..device import Device, get_device
from ..layout import SAMPLERS
from .tracer import trace_defines
from .work_layout import read_items


def sample_offsets(pixels, sampler: str, n: int, seed: int = 0, device: Device | None = None) -> np.ndarray:
    """(len(pixels), n*n, 2) float32 offsets of each pixel's samples."""
    dev = device or get_device()
    pixels = np.asarray(pixels, np.int32).ravel()
    k = len(pixels)
    knl = dev.kernel("trace.cl", "sample_offsets", trace_defines())  # the renderer's own build
    args = dict(pixels=dev.to_device(pixels), n_work=k, sampler=SAMPLERS[sampler], samples_per_side=n, seed=seed)
    return read_items(dev, knl, k, (k, n * n, 2), np.float32, **args)


def sequence_points(pixels, samples: int, dims, seed: int = 0, first: int = 0, scrambled: bool = True, device: Device | None = None) -> np.ndarray:
    """(len(pixels), samples, len(dims)) uint32: dimensions `dims` of samples first ... first + samples - 1 of each
    pixel in the path tracer's Sobol sequence (kernels/sobol.h), as 32-bit fractions (value / 2**32); unscrambled:
    the plain 2-D Sobol coordinate dim % 2 of the sample index, the same for every pixel."""
    dev = device or get_device()
    pixels = np.asarray(pixels, np.uint32).ravel()
    dims = np.asarray(dims, np.uint32).ravel()
    k = len(pixels) * samples
    knl = dev.kernel("sobol_probe.cl", "sobol_probe")
    args = dict(pixels=dev.to_device(pixels), n_samples=samples, first=first, n_work=k, dims=dev.to_device(dims), n_dims=len(dims))
    return read_items(dev, knl, k, (len(pixels), samples, len(dims)), np.uint32, **args, seed=seed, scrambled=int(scrambled))
