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


def _points(pixels, samples: int, lanes: int, device: Device | None):
    """The probe's device, kernel program defines and the per-point arguments of `samples` samples of each pixel."""
    dev = device or get_device()
    pixels = np.asarray(pixels, np.uint32).ravel()
    k = len(pixels) * samples
    return dev, {"LANES": lanes}, k, dict(pixels=dev.to_device(pixels), n_samples=samples, n_work=k)


def sequence_points(
    pixels, samples: int, dims, seed: int = 0, first: int = 0, scrambled: bool = True, device: Device | None = None, lanes: int = 1
) -> np.ndarray:
    """(len(pixels), samples, len(dims)) uint32: dimensions `dims` of samples first ... first + samples - 1 of each
    pixel in the path tracer's Sobol sequence (kernels/sobol.h), as 32-bit fractions (value / 2**32); unscrambled:
    the plain 2-D Sobol coordinate dim % 2 of the sample index, the same for every pixel.  `lanes`: points a
    work-item, one in each lane (kernels/lanes.h: 1, 8 or 16), which give the same bits."""
    dev, defines, k, args = _points(pixels, samples, lanes, device)
    dims = np.asarray(dims, np.uint32).ravel()
    knl = dev.kernel("sobol_probe.cl", "sobol_probe", defines)
    args.update(first=first, dims=dev.to_device(dims), n_dims=len(dims), seed=seed, scrambled=int(scrambled))
    return read_items(dev, knl, -(-k // lanes), (k // samples, samples, len(dims)), np.uint32, **args)


PATH_DRAWS = 9  # kernels/sobol_probe.cl path_draws_probe: a vertex's draws, in the order it takes them


def path_draws(pixels, samples: int, depth: int, seed: int = 0, first: int = 0, device: Device | None = None, lanes: int = 1) -> np.ndarray:
    """(len(pixels), samples, depth, PATH_DRAWS) float32: the Sobol sampler's numbers as the path tracer draws them at
    each vertex through its Rng (kernels/sobol_probe.cl path_draws_probe lists them), in `lanes` (1, 8 or 16)."""
    dev, defines, k, args = _points(pixels, samples, lanes, device)
    knl = dev.kernel("sobol_probe.cl", "path_draws_probe", defines)
    args.update(first=first, depth=depth, seed=seed)
    return read_items(dev, knl, -(-k // lanes), (k // samples, samples, depth, PATH_DRAWS), np.float32, **args)
